// Whole numbers as a person writes them: the command line and configuration files take a whole number
// only in this form, since the C library's readers and yaml-cpp take 010 as octal 8 and 0x100 as 256.
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

}  // namespace chungs
