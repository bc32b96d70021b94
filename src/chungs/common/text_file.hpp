// Reading whitespace- or comma-separated text tables (trajectories, calibration, index files) with
// errors that name the file and line.
#pragma once
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "chungs/common/error.hpp"

namespace chungs {

struct TextLine {
  std::filesystem::path file;
  int number = 0;                   // 1-based line number in the file
  std::vector<std::string> tokens;  // fields, separators and surrounding blanks removed

  // Parses token i as a finite number; throws "FILE:LINE: ..." otherwise.
  double number_at(size_t i) const;
  long long integer_at(size_t i) const;
  // Throws unless the line has exactly n (or at least n when at_least) fields.
  void expect_fields(size_t n, bool at_least = false) const;
  [[noreturn]] void fail_here(const std::string& msg) const;
};

// Reads every non-empty line that does not start with '#' (and is not a header when
// skip_header_if_not_numeric: its first field is not a number). Separators: blanks, and commas
// when comma_separated.
std::vector<TextLine> read_text_table(const std::filesystem::path& file, bool comma_separated = false,
                                      bool skip_header_if_not_numeric = false);
// The same lines one at a time, for files that may be large; `fn` returns false to stop reading.
void for_each_text_line(const std::filesystem::path& file, bool comma_separated, bool skip_header_if_not_numeric,
                        const std::function<bool(const TextLine&)>& fn);

// Parses a string as a finite double; nullopt-free: throws Error naming `what` on failure.
double parse_double(const std::string& s, const std::string& what);
bool is_number(const std::string& s);

// Throws naming the file when JSON text nests arrays and objects deeper than max_depth: a report.json of
// 100,000 '[' crashed a reader (the stack ran out), where a file of its size must give one clear error.
void require_json_nesting(const std::string& text, const std::filesystem::path& file, size_t max_depth = 256);

// Whole file as a string; throws naming the file when it cannot be read.
std::string read_file_text(const std::filesystem::path& file);

}  // namespace chungs
