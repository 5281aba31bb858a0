// Strict parsing of the small text files datasets ship (lists, trajectories, plans), with errors naming file and line.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace qsg::replay {

// One non-blank, non-comment line of a text file, split on spaces and tabs.
struct TextLine {
  int line_number = 0;  // 1-based, as an editor shows it
  std::vector<std::string> fields;
};

// Reads `path` and returns its data lines; lines whose first non-blank character is '#' are comments.
// Returns false with "<path>: cannot open" when the file cannot be read.
bool read_text_lines(const std::string& path, std::vector<TextLine>* lines, std::string* error);
// The same for text already in memory.
void split_text_lines(const std::string& text, std::vector<TextLine>* lines);

// Parses the whole field as a finite double ("1e-3", "-0.5"); rejects trailing junk, "nan" and "inf".
bool parse_double(const std::string& field, double* value);
// Parses a whole non-negative or negative integer.
bool parse_int64(const std::string& field, std::int64_t* value);
// Parses a timestamp in seconds ("1305031102.175304") to nanoseconds without going through a double, so
// TUM's 16-digit stamps round-trip exactly; exponent forms are accepted through a double.
bool parse_seconds_to_ns(const std::string& field, std::int64_t* value_ns);
// Formats nanoseconds as seconds with 6 decimals (TUM's convention), exactly (no floating point).
std::string format_ns_as_seconds(std::int64_t time_ns);

// "<path>:<line>: <message>"
std::string error_at(const std::string& path, int line_number, const std::string& message);

// Joins a dataset folder and a file name from a list; absolute names are kept as they are.
std::string join_path(const std::string& folder, const std::string& name);
bool file_exists(const std::string& path);

}  // namespace qsg::replay
