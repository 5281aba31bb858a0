// Strict field parsing: TUM stamps to nanoseconds exactly, finite numbers only, comments and blank lines skipped.
#include "drivers/replay/text_parse.h"

#include <gtest/gtest.h>

namespace qsg::replay {
namespace {

TEST(TextParse, SecondsToNanosecondsIsExact) {
  std::int64_t ns = 0;
  ASSERT_TRUE(parse_seconds_to_ns("1305031102.175304", &ns));
  EXPECT_EQ(ns, 1305031102175304000LL);  // through a double this would be off by up to ~100 ns
  ASSERT_TRUE(parse_seconds_to_ns("0.000000001", &ns));
  EXPECT_EQ(ns, 1);
  ASSERT_TRUE(parse_seconds_to_ns("12", &ns));
  EXPECT_EQ(ns, 12'000'000'000LL);
  ASSERT_TRUE(parse_seconds_to_ns(".5", &ns));
  EXPECT_EQ(ns, 500'000'000LL);
  ASSERT_TRUE(parse_seconds_to_ns("-1.25", &ns));
  EXPECT_EQ(ns, -1'250'000'000LL);
  ASSERT_TRUE(parse_seconds_to_ns("1.0000000015", &ns));  // rounds on the tenth digit
  EXPECT_EQ(ns, 1'000'000'002LL);
  ASSERT_TRUE(parse_seconds_to_ns("1.5e-3", &ns));
  EXPECT_EQ(ns, 1'500'000LL);
  for (const char* bad : {"", ".", "-", "abc", "1.2.3", "12s", "nan", "inf", "1e400", "0x10"}) {
    EXPECT_FALSE(parse_seconds_to_ns(bad, &ns)) << bad;
  }
}

// Found by fuzz_tum: ten digits of seconds past 9.22e9 overflowed int64 nanoseconds (undefined behaviour). Both
// paths now stop at 9e9 s.
TEST(TextParse, SecondsBeyondTheInt64RangeAreRefusedNotWrapped) {
  std::int64_t ns = 0;
  ASSERT_TRUE(parse_seconds_to_ns("9000000000.999999999", &ns));
  EXPECT_EQ(ns, 9'000'000'000'999'999'999LL);
  ASSERT_TRUE(parse_seconds_to_ns("-9000000000", &ns));
  EXPECT_EQ(ns, -9'000'000'000'000'000'000LL);
  for (const char* bad : {"9305031098.6659", "9999999999", "-9223372037.0", "9000000001", "9.1e9"}) {
    EXPECT_FALSE(parse_seconds_to_ns(bad, &ns)) << bad;
  }
}

TEST(TextParse, FormatsNanosecondsAsTumSeconds) {
  EXPECT_EQ(format_ns_as_seconds(1305031102175304000LL), "1305031102.175304");
  EXPECT_EQ(format_ns_as_seconds(0), "0.000000");
  EXPECT_EQ(format_ns_as_seconds(1'999'999'600LL), "2.000000");  // rounded to the microsecond
  EXPECT_EQ(format_ns_as_seconds(-1'500'000LL), "-0.001500");
  std::int64_t back = 0;
  ASSERT_TRUE(parse_seconds_to_ns(format_ns_as_seconds(123'456'789'000LL), &back));
  EXPECT_EQ(back, 123'456'789'000LL);
}

TEST(TextParse, NumbersMustBeWholeAndFinite) {
  double d = 0.0;
  EXPECT_TRUE(parse_double("-2.5e-3", &d));
  EXPECT_EQ(d, -2.5e-3);
  for (const char* bad : {"", "1.0x", "nan", "inf", "-inf", " 1", "1 ", "1e999", "0x1p3"}) {
    EXPECT_FALSE(parse_double(bad, &d)) << bad;
  }
  std::int64_t i = 0;
  EXPECT_TRUE(parse_int64("-42", &i));
  EXPECT_EQ(i, -42);
  EXPECT_FALSE(parse_int64("4.2", &i));
  EXPECT_FALSE(parse_int64("99999999999999999999", &i));
}

TEST(TextParse, SplitsLinesSkippingCommentsAndBlanks) {
  std::vector<TextLine> lines;
  split_text_lines("# header\n\n  1 a.png\r\n\t2\tb.png  # not a comment mid-line\n#x\n3 c", &lines);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0].line_number, 3);
  EXPECT_EQ(lines[0].fields, (std::vector<std::string>{"1", "a.png"}));
  EXPECT_EQ(lines[1].line_number, 4);
  EXPECT_EQ(lines[1].fields.size(), 7u);  // '#' only starts a comment at the start of a line
  EXPECT_EQ(lines[2].line_number, 6);
  EXPECT_EQ(lines[2].fields, (std::vector<std::string>{"3", "c"}));
}

TEST(TextParse, JoinPathKeepsAbsoluteNames) {
  EXPECT_EQ(join_path("/data/tum", "rgb/1.png"), "/data/tum/rgb/1.png");
  EXPECT_EQ(join_path("/data/tum/", "rgb.txt"), "/data/tum/rgb.txt");
  EXPECT_EQ(join_path("/data/tum", "/abs/x.png"), "/abs/x.png");
}

}  // namespace
}  // namespace qsg::replay
