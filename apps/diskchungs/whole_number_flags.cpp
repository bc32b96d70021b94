#include "whole_number_flags.hpp"

#include <charconv>
#include <cstdint>
#include <limits>
#include <string_view>

#include "chungs/common/decimal.hpp"
#include "chungs/common/error.hpp"

namespace chungs::app {

namespace {

// Written in decimal and within T (from_chars refuses a minus sign for an unsigned T, and knows no '+').
template <class T>
bool reads_as_written(std::string_view text) {
  if (!written_in_decimal(text)) return false;
  if (text[0] == '+') text.remove_prefix(1);
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size();
}

std::string refusal(const CLI::Option& option, const std::string& text, bool is_unsigned) {
  if (is_unsigned)
    return cat(option.get_name(), " must be a whole number from 0 to ", std::numeric_limits<uint64_t>::max(),
               " written in decimal, got ", text);
  return cat(option.get_name(), " must be a whole number written in decimal that fits in 64 bits, got ", text);
}

std::string misread_in(const CLI::Option& option) {
  if (option.count() == 0) return {};
  // The type CLI11 read the flag as, before any ":" that names the flag's validators.
  const std::string full = option.get_type_name();
  const std::string type = full.substr(0, full.find(':'));
  for (const std::string& text : option.results()) {
    if (type == "INT" && !reads_as_written<int64_t>(text)) return refusal(option, text, false);
    if (type == "UINT" && !reads_as_written<uint64_t>(text)) return refusal(option, text, true);
  }
  return {};
}

}  // namespace

std::string misread_whole_number(const CLI::App& app) {
  for (const CLI::Option* option : app.get_options())
    if (std::string why = misread_in(*option); !why.empty()) return why;
  for (const CLI::App* sub : app.get_subcommands())  // the parsed ones
    if (std::string why = misread_whole_number(*sub); !why.empty()) return why;
  return {};
}

}  // namespace chungs::app
