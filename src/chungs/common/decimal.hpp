// Numbers as a person writes them: the command line and configuration files take a whole number only in
// this form, since the C library's readers and yaml-cpp take 010 as octal 8 and 0x100 as 256.
#pragma once
#include <algorithm>
#include <string_view>

namespace chungs {

// Decimal digits after at most one sign, without a leading zero (0 itself excepted). The range is the
// reader's to check.
inline bool written_in_decimal(std::string_view text) {
  if (!text.empty() && (text[0] == '-' || text[0] == '+')) text.remove_prefix(1);
  return !text.empty() && (text.size() == 1 || text[0] != '0') &&
         std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// Text a decimal (floating-point) reader takes as the number it shows: not empty, no blanks around it
// (strtod skips leading ones), not hexadecimal (strtod reads 0x10 as 16 and 0x1p3 as 8). Whether the rest
// is a number, and in range, is the reader's to check.
inline bool shows_a_decimal_number(std::string_view text) {
  auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; };
  return !text.empty() && !blank(text.front()) && !blank(text.back()) &&
         text.find_first_of("xX") == std::string_view::npos;
}

}  // namespace chungs
