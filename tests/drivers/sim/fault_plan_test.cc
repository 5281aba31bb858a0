// Fault plan files: the text and JSON formats parse to the same plan; malformed plans name the line or field.
#include "drivers/sim/fault_plan.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace qsg::sim {
namespace {

constexpr const char* kTextPlan = R"(# every kind once
seed 42
rate drop 0.01
rate depth_zero 0.5
random stall_reads=4 unplug_reads=7 delay_ms=20 back_ms=3 region=16x8
at 10 drop
at 12 stall reads=3
at 15 late delay_ms=80
at 20 backwards back_ms=5
at 25 depth_nan rect=10,20,40,30
at 26 depth_zero rect=0,0,8,8
at 27 depth_saturated rect=1,2,3,4
at 30 wrong_size
at 40 unplug reads=5   # trailing comment
)";

constexpr const char* kJsonPlan = R"({
  "seed": 42,
  "rates": {"drop": 0.01, "depth_zero": 0.5},
  "random": {"stall_reads": 4, "unplug_reads": 7, "delay_ms": 20, "back_ms": 3, "region": [16, 8]},
  "events": [
    {"at": 10, "fault": "drop"},
    {"at": 12, "fault": "stall", "reads": 3},
    {"at": 15, "fault": "late", "delay_ms": 80},
    {"at": 20, "fault": "backwards", "back_ms": 5},
    {"at": 25, "fault": "depth_nan", "rect": [10, 20, 40, 30]},
    {"at": 26, "fault": "depth_zero", "rect": [0, 0, 8, 8]},
    {"at": 27, "fault": "depth_saturated", "rect": [1, 2, 3, 4]},
    {"at": 30, "fault": "wrong_size"},
    {"at": 40, "fault": "unplug", "reads": 5}
  ]
})";

void expect_example_plan(const FaultPlan& plan) {
  EXPECT_EQ(plan.random.seed, 42u);
  EXPECT_DOUBLE_EQ(plan.random.rate[static_cast<int>(FaultKind::kDrop)], 0.01);
  EXPECT_DOUBLE_EQ(plan.random.rate[static_cast<int>(FaultKind::kDepthZero)], 0.5);
  EXPECT_DOUBLE_EQ(plan.random.rate[static_cast<int>(FaultKind::kStall)], 0.0);
  EXPECT_EQ(plan.random.stall_reads, 4);
  EXPECT_EQ(plan.random.unplug_reads, 7);
  EXPECT_EQ(plan.random.delay_ns, 20'000'000);
  EXPECT_EQ(plan.random.back_ns, 3'000'000);
  EXPECT_EQ(plan.random.region_width_px, 16);
  EXPECT_EQ(plan.random.region_height_px, 8);
  EXPECT_TRUE(plan.has_random_faults());
  ASSERT_EQ(plan.events.size(), 9u);
  const FaultKind kinds[] = {FaultKind::kDrop,      FaultKind::kStall,      FaultKind::kLate,
                             FaultKind::kTimestampBackwards, FaultKind::kDepthNan, FaultKind::kDepthZero,
                             FaultKind::kDepthSaturated,     FaultKind::kWrongSize, FaultKind::kUnplug};
  const std::uint64_t seqs[] = {10, 12, 15, 20, 25, 26, 27, 30, 40};
  for (int i = 0; i < 9; ++i) {
    EXPECT_EQ(plan.events[i].kind, kinds[i]) << i;
    EXPECT_EQ(plan.events[i].sequence, seqs[i]) << i;
  }
  EXPECT_EQ(plan.events[1].reads, 3);
  EXPECT_EQ(plan.events[2].delay_ns, 80'000'000);
  EXPECT_EQ(plan.events[3].back_ns, 5'000'000);
  EXPECT_EQ(plan.events[4].rect.x_px, 10);
  EXPECT_EQ(plan.events[4].rect.y_px, 20);
  EXPECT_EQ(plan.events[4].rect.width_px, 40);
  EXPECT_EQ(plan.events[4].rect.height_px, 30);
  EXPECT_EQ(plan.events[8].reads, 5);
}

TEST(FaultPlanText, ParsesEveryDirective) {
  FaultPlan plan;
  std::string error;
  ASSERT_TRUE(parse_fault_plan_text(kTextPlan, "plan.txt", &plan, &error)) << error;
  expect_example_plan(plan);
  EXPECT_EQ(plan.events[0].line_number, 6);
}

TEST(FaultPlanJson, ParsesTheSamePlan) {
  FaultPlan plan;
  std::string error;
  ASSERT_TRUE(parse_fault_plan_json(kJsonPlan, "plan.json", &plan, &error)) << error;
  expect_example_plan(plan);
}

TEST(FaultPlanFile, LoadPicksTheFormatByExtension) {
  const std::string dir = ::testing::TempDir();
  const std::string txt = dir + "/qsg_plan_" + std::to_string(::getpid()) + ".txt";
  const std::string json = dir + "/qsg_plan_" + std::to_string(::getpid()) + ".json";
  std::ofstream(txt) << kTextPlan;
  std::ofstream(json) << kJsonPlan;
  FaultPlan a, b;
  std::string error;
  ASSERT_TRUE(load_fault_plan(txt, &a, &error)) << error;
  ASSERT_TRUE(load_fault_plan(json, &b, &error)) << error;
  expect_example_plan(a);
  expect_example_plan(b);
  EXPECT_FALSE(load_fault_plan(dir + "/no_such_plan.txt", &a, &error));
  EXPECT_NE(error.find("no_such_plan.txt: cannot open"), std::string::npos) << error;
  std::remove(txt.c_str());
  std::remove(json.c_str());
}

struct BadText {
  const char* text;
  const char* expected;  // substring of the error
};

TEST(FaultPlanText, ErrorsNameTheLineAndTheProblem) {
  const BadText cases[] = {
      {"seed 1\nat 3 dorp\n", "plan.txt:2: unknown fault 'dorp'"},
      {"at x drop\n", "plan.txt:1: sequence 'x'"},
      {"at -3 drop\n", "plan.txt:1: sequence '-3'"},
      {"\n\nat 3 stall reads=0\n", "plan.txt:3: bad value '0' for 'reads'"},
      {"at 3 drop reads=2\n", "plan.txt:1: 'reads' does not apply to fault 'drop'"},
      {"at 3 depth_nan\n", "plan.txt:1: fault 'depth_nan' needs rect"},
      {"at 3 depth_nan rect=1,2,3\n", "plan.txt:1: bad value '1,2,3' for 'rect'"},
      {"at 3 depth_nan rect=1,2,0,4\n", "plan.txt:1: bad value"},
      {"at 3 late delay_ms=-5\n", "plan.txt:1: bad value '-5' for 'delay_ms'"},
      {"at 3 late colour=red\n", "plan.txt:1: unknown key 'colour'"},
      {"rate drop 1.5\n", "plan.txt:1: probability '1.5' is not in [0, 1]"},
      {"rate drop\n", "plan.txt:1: expected 'rate <fault> <probability>'"},
      {"seed -1\n", "plan.txt:1: expected 'seed <unsigned integer>'"},
      {"random region=16\n", "plan.txt:1: bad value '16' for 'region'"},
      {"frobnicate 3\n", "plan.txt:1: unknown directive 'frobnicate'"},
      {"at 3 pose_jump samples=2\n", "plan.txt:1: fault 'pose_jump' needs offset_m"},
      {"at 3 pose_jump offset_m=1,2\n", "plan.txt:1: bad value '1,2' for 'offset_m'"},
      {"at 3 pose_jump offset_m=1,2,1e9\n", "plan.txt:1: bad value"},
      {"at 3 drop samples=2\n", "plan.txt:1: 'samples' does not apply to fault 'drop'"},
      {"at 3 dropout samples=0\n", "plan.txt:1: bad value '0' for 'samples'"},
      {"rate pose_jump 0.1\n", "plan.txt:1: pose_jump has no random rate"},
      {"random until=x\n", "plan.txt:1: bad value 'x' for 'until'"},
  };
  for (const BadText& c : cases) {
    FaultPlan plan;
    std::string error;
    EXPECT_FALSE(parse_fault_plan_text(c.text, "plan.txt", &plan, &error)) << c.text;
    EXPECT_NE(error.find(c.expected), std::string::npos) << "input: " << c.text << "\nerror: " << error;
  }
}

TEST(FaultPlanJson, ErrorsNameTheField) {
  const BadText cases[] = {
      {"{\"events\": [{\"at\": 1, \"fault\": \"drop\"}, {\"at\": 2, \"fault\": \"stall\", \"reads\": -1}]}",
       "plan.json: events[1].reads: expected a positive integer"},
      {"{\"events\": [{\"fault\": \"drop\"}]}", "plan.json: events[0].at:"},
      {"{\"events\": [{\"at\": 1, \"fault\": \"dorp\"}]}", "plan.json: events[0].fault: expected one of drop"},
      {"{\"events\": [{\"at\": 1, \"fault\": \"depth_zero\"}]}", "plan.json: events[0].rect: required"},
      {"{\"events\": [{\"at\": 1, \"fault\": \"depth_zero\", \"rect\": [1, 2, 3]}]}", "plan.json: events[0].rect:"},
      {"{\"events\": [{\"at\": 1, \"fault\": \"drop\", \"delay_ms\": 3}]}",
       "plan.json: events[0].delay_ms: does not apply to fault 'drop'"},
      {"{\"rates\": {\"stall\": 2}}", "plan.json: rates.stall: expected a probability"},
      {"{\"rates\": {\"stal\": 0.1}}", "plan.json: rates.stal: unknown fault"},
      {"{\"random\": {\"region\": [0, 3]}}", "plan.json: random.region[0]: expected a positive integer"},
      {"{\"seed\": -4}", "plan.json: seed: expected an unsigned integer"},
      {"{\"sead\": 4}", "plan.json: sead: unknown key"},
      {"[1, 2]", "plan.json: (top level): expected an object"},
      {"{\"seed\": 4,,}", "plan.json: [json.exception.parse_error"},
      {"{\"events\": [{\"at\": 1, \"fault\": \"pose_jump\"}]}", "plan.json: events[0].offset_m: required"},
      {"{\"events\": [{\"at\": 1, \"fault\": \"pose_jump\", \"offset_m\": [1, \"a\", 2]}]}",
       "plan.json: events[0].offset_m: expected [x, y, z]"},
      {"{\"events\": [{\"at\": 1, \"fault\": \"dropout\", \"samples\": 1.5}]}",
       "plan.json: events[0].samples: expected a positive integer"},
      {"{\"rates\": {\"pose_jump\": 0.1}}", "plan.json: rates.pose_jump: no random rate"},
      {"{\"random\": {\"from\": -1}}", "plan.json: random.from: expected an unsigned integer"},
  };
  for (const BadText& c : cases) {
    FaultPlan plan;
    std::string error;
    EXPECT_FALSE(parse_fault_plan_json(c.text, "plan.json", &plan, &error)) << c.text;
    EXPECT_NE(error.find(c.expected), std::string::npos) << "input: " << c.text << "\nerror: " << error;
  }
}

TEST(FaultPlanJson, ParsesDropoutPoseJumpAndTheRandomWindow) {
  FaultPlan plan;
  std::string error;
  ASSERT_TRUE(parse_fault_plan_json(
      "{\"rates\": {\"dropout\": 0.1}, \"random\": {\"from\": 10, \"until\": 20, \"dropout_samples\": 4},"
      " \"events\": [{\"at\": 3, \"fault\": \"pose_jump\", \"offset_m\": [1, -2, 0.5], \"samples\": 2},"
      " {\"at\": 5, \"fault\": \"dropout\", \"samples\": 7}]}",
      "plan.json", &plan, &error))
      << error;
  EXPECT_EQ(plan.random.from, 10u);
  EXPECT_EQ(plan.random.until, 20u);
  EXPECT_EQ(plan.random.dropout_samples, 4);
  EXPECT_DOUBLE_EQ(plan.random.rate[static_cast<int>(FaultKind::kDropout)], 0.1);
  ASSERT_EQ(plan.events.size(), 2u);
  EXPECT_EQ(plan.events[0].kind, FaultKind::kPoseJump);
  EXPECT_EQ(plan.events[0].samples, 2);
  EXPECT_DOUBLE_EQ(plan.events[0].offset_m[1], -2.0);
  EXPECT_EQ(plan.events[1].kind, FaultKind::kDropout);
  EXPECT_EQ(plan.events[1].samples, 7);
}

TEST(FaultPlan, PrintListsEveryEvent) {
  FaultPlan plan;
  std::string error;
  ASSERT_TRUE(parse_fault_plan_text(kTextPlan, "plan.txt", &plan, &error)) << error;
  char buffer[4096] = {};
  std::FILE* out = fmemopen(buffer, sizeof(buffer) - 1, "w");
  ASSERT_NE(out, nullptr);
  plan.print(out);
  std::fclose(out);
  const std::string text(buffer);
  EXPECT_NE(text.find("9 events, seed 42"), std::string::npos) << text;
  EXPECT_NE(text.find("at 40 unplug reads=5"), std::string::npos) << text;
}

}  // namespace
}  // namespace qsg::sim
