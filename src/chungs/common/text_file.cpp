#include "chungs/common/text_file.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace chungs {

namespace {
bool parse(const std::string& s, double& out) {
  const char* b = s.data();
  const char* e = b + s.size();
  auto r = std::from_chars(b, e, out);
  return r.ec == std::errc() && r.ptr == e && std::isfinite(out);
}
}  // namespace

bool is_number(const std::string& s) {
  double v;
  return parse(s, v);
}

double parse_double(const std::string& s, const std::string& what) {
  double v;
  if (!parse(s, v)) fail(what, ": '", s, "' is not a finite number");
  return v;
}

void TextLine::fail_here(const std::string& msg) const {
  fail(file.string(), ":", number, ": ", msg);
}

double TextLine::number_at(size_t i) const {
  if (i >= tokens.size()) fail_here(cat("expected at least ", i + 1, " fields, found ", tokens.size()));
  double v;
  if (!parse(tokens[i], v)) fail_here(cat("field ", i + 1, " '", tokens[i], "' is not a finite number"));
  return v;
}

long long TextLine::integer_at(size_t i) const {
  if (i >= tokens.size()) fail_here(cat("expected at least ", i + 1, " fields, found ", tokens.size()));
  long long v = 0;
  const auto& s = tokens[i];
  auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size())
    fail_here(cat("field ", i + 1, " '", s, "' is not an integer"));
  return v;
}

void TextLine::expect_fields(size_t n, bool at_least) const {
  if (tokens.size() == n || (at_least && tokens.size() > n)) return;
  fail_here(cat("expected ", at_least ? "at least " : "", n, " fields, found ", tokens.size()));
}

std::string read_file_text(const std::filesystem::path& file) {
  require_file(file);
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file.string(), ": cannot open for reading");
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

void require_json_nesting(const std::string& text, const std::filesystem::path& file, size_t max_depth) {
  size_t depth = 0;
  bool in_string = false, escaped = false;
  for (const char c : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) fail(file.string(), ": JSON nested deeper than ", max_depth, " levels");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

void for_each_text_line(const std::filesystem::path& file, bool comma_separated, bool skip_header_if_not_numeric,
                        const std::function<bool(const TextLine&)>& fn) {
  // Line by line: a 36 MB trajectory read whole, as strings of tokens per line, took 800 MB.
  require_file(file);
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file.string(), ": cannot open for reading");
  std::string line;
  int number = 0;
  bool first_data_line = true;
  TextLine tl{file, 0, {}};
  while (std::getline(in, line)) {
    ++number;
    // A UTF-8 byte order mark (an editor's, on Windows) made the first line read as a header, and a
    // trajectory lost its first pose without a word.
    if (number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    tl.number = number;
    tl.tokens.clear();
    std::string cur;
    auto flush = [&] {
      if (!cur.empty()) tl.tokens.push_back(cur);
      cur.clear();
    };
    for (char c : line) {
      if (c == ' ' || c == '\t' || c == '\r' || (comma_separated && c == ',')) {
        flush();
      } else {
        cur.push_back(c);
      }
    }
    flush();
    if (tl.tokens.empty() || tl.tokens[0][0] == '#') continue;
    if (first_data_line && skip_header_if_not_numeric && !is_number(tl.tokens[0])) {
      first_data_line = false;
      continue;
    }
    first_data_line = false;
    if (!fn(tl)) return;
  }
  if (in.bad()) fail(file.string(), ": read failed");
}

std::vector<TextLine> read_text_table(const std::filesystem::path& file, bool comma_separated,
                                      bool skip_header_if_not_numeric) {
  std::vector<TextLine> out;
  for_each_text_line(file, comma_separated, skip_header_if_not_numeric, [&](const TextLine& l) {
    out.push_back(l);
    return true;
  });
  return out;
}

}  // namespace chungs
