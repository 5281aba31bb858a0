// Strict text-field parsing for dataset files.
#include "drivers/replay/text_parse.h"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace qsg::replay {

void split_text_lines(const std::string& text, std::vector<TextLine>* lines) {
  lines->clear();
  int line_number = 0;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    ++line_number;
    TextLine line;
    line.line_number = line_number;
    std::size_t i = pos;
    while (i < end) {
      while (i < end && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r')) ++i;
      if (i >= end) break;
      if (line.fields.empty() && text[i] == '#') break;  // comment line
      const std::size_t start = i;
      while (i < end && text[i] != ' ' && text[i] != '\t' && text[i] != '\r') ++i;
      line.fields.emplace_back(text, start, i - start);
    }
    if (!line.fields.empty()) lines->push_back(std::move(line));
    if (end == text.size()) break;
    pos = end + 1;
  }
}

bool read_text_lines(const std::string& path, std::vector<TextLine>* lines, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (error) *error = path + ": cannot open";
    return false;
  }
  std::ostringstream text;
  text << in.rdbuf();
  split_text_lines(text.str(), lines);
  return true;
}

bool parse_double(const std::string& field, double* value) {
  if (field.empty()) return false;
  // Plain decimal notation only: strtod would also take leading blanks, hex floats, "nan" and "inf".
  for (const char c : field) {
    if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E')) return false;
  }
  const char* begin = field.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end != begin + field.size() || errno == ERANGE || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

bool parse_int64(const std::string& field, std::int64_t* value) {
  if (field.empty() || field[0] == ' ' || field[0] == '\t') return false;
  const char* begin = field.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(begin, &end, 10);
  if (end != begin + field.size() || errno == ERANGE) return false;
  *value = static_cast<std::int64_t>(v);
  return true;
}

bool parse_seconds_to_ns(const std::string& field, std::int64_t* value_ns) {
  constexpr std::int64_t kMaxSeconds = 9'000'000'000;  // year 2255; 9e18 ns fits in int64
  if (field.empty()) return false;
  std::size_t i = 0;
  bool negative = false;
  if (field[0] == '-' || field[0] == '+') {
    negative = field[0] == '-';
    i = 1;
  }
  std::int64_t whole = 0;
  std::int64_t frac_ns = 0;
  int whole_digits = 0;
  int frac_digits = 0;
  bool plain = true;
  for (; i < field.size() && field[i] != '.'; ++i) {
    const char c = field[i];
    if (c < '0' || c > '9' || whole_digits >= 10) {  // 10 digits of seconds: beyond year 2286, or not plain
      plain = false;
      break;
    }
    whole = whole * 10 + (c - '0');
    ++whole_digits;
  }
  if (plain && i < field.size()) {  // at '.'
    ++i;
    for (; i < field.size(); ++i) {
      const char c = field[i];
      if (c < '0' || c > '9') {
        plain = false;
        break;
      }
      if (frac_digits < 9) {
        frac_ns = frac_ns * 10 + (c - '0');
        ++frac_digits;
      } else if (frac_digits == 9) {
        if (c >= '5') ++frac_ns;  // round half up on the first dropped digit
        ++frac_digits;
      }
    }
  }
  // Past 9e9 s the nanoseconds leave int64 (9.22e18); the double path below refuses those, as it does any form.
  if (whole > kMaxSeconds) plain = false;
  if (plain && (whole_digits > 0 || frac_digits > 0)) {
    for (int d = std::min(frac_digits, 9); d < 9; ++d) frac_ns *= 10;
    const std::int64_t ns = whole * 1000000000LL + frac_ns;
    *value_ns = negative ? -ns : ns;
    return true;
  }
  // Exponent or very large forms: go through a double (loses sub-microsecond precision on epoch stamps).
  double seconds = 0.0;
  if (!parse_double(field, &seconds) || std::fabs(seconds) > static_cast<double>(kMaxSeconds)) return false;
  *value_ns = std::llround(seconds * 1e9);
  return true;
}

std::string format_ns_as_seconds(std::int64_t time_ns) {
  // Round to the nearest microsecond, then print integer parts: exact for any 64-bit stamp.
  const bool negative = time_ns < 0;
  const std::uint64_t magnitude_ns = negative ? static_cast<std::uint64_t>(-(time_ns + 1)) + 1u
                                              : static_cast<std::uint64_t>(time_ns);
  const std::uint64_t us = (magnitude_ns + 500u) / 1000u;
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%s%llu.%06llu", negative ? "-" : "",
                static_cast<unsigned long long>(us / 1000000u), static_cast<unsigned long long>(us % 1000000u));
  return buffer;
}

std::string error_at(const std::string& path, int line_number, const std::string& message) {
  return path + ":" + std::to_string(line_number) + ": " + message;
}

std::string join_path(const std::string& folder, const std::string& name) {
  if (name.empty() || name[0] == '/' || folder.empty()) return name;
  if (folder.back() == '/') return folder + name;
  return folder + "/" + name;
}

bool file_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

}  // namespace qsg::replay
