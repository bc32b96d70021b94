#include "number_flags.hpp"

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

std::string not_decimal(const std::string& name, const std::string& text) {
  return cat(name, " must be a whole number written in decimal, got ", text);
}

// Decimal text beyond T names the end it passed: "--budget must be at most 9223372036854775807" rather
// than a range from a negative number that no budget could take.
template <class T>
std::string out_of_range(const std::string& name, const std::string& text) {
  if (text[0] == '-')
    return cat(name, " must be a whole number at least ", +std::numeric_limits<T>::min(), ", got ", text);
  return cat(name, " must be a whole number at most ", +std::numeric_limits<T>::max(), ", got ", text);
}

std::string refusal(const CLI::Option& option, const std::string& text, bool is_unsigned) {
  // Not decimal (0x10, 1e3): the notation is at fault whatever the flag's width.
  if (!written_in_decimal(text)) return not_decimal(option.get_name(), text);
  // Decimal text CLI11 kept but that does not read back: beyond 64 bits (32-bit flags refuse it earlier).
  return is_unsigned ? out_of_range<uint64_t>(option.get_name(), text)
                     : out_of_range<int64_t>(option.get_name(), text);
}

// The type CLI11 reads the flag as (INT, UINT, FLOAT, ...), before any ":" that names its validators.
std::string read_as(const CLI::Option& option) {
  const std::string full = option.get_type_name();
  return full.substr(0, full.find(':'));
}

// Any option of the app's tree, parsed or not, by one of its names.
const CLI::Option* find_option(const CLI::App& app, const std::string& name) {
  for (const CLI::Option* option : app.get_options())
    if (option->check_name(name)) return option;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    if (const CLI::Option* found = find_option(*sub, name)) return found;
  return nullptr;
}

std::string misread_in(const CLI::Option& option) {
  if (option.count() == 0) return {};
  const std::string type = read_as(option);
  for (const std::string& text : option.results()) {
    if (type == "INT" && !reads_as_written<int64_t>(text)) return refusal(option, text, false);
    if (type == "UINT" && !reads_as_written<uint64_t>(text)) return refusal(option, text, true);
    if (type == "FLOAT" && !shows_a_decimal_number(text))
      return cat(option.get_name(), " must be a number written in decimal, got ",
                 text.empty() ? std::string("an empty value") : "'" + text + "'");
  }
  return {};
}

}  // namespace

std::string misread_number(const CLI::App& app) {
  for (const CLI::Option* option : app.get_options())
    if (std::string why = misread_in(*option); !why.empty()) return why;
  for (const CLI::App* sub : app.get_subcommands())  // the parsed ones
    if (std::string why = misread_number(*sub); !why.empty()) return why;
  return {};
}

std::string conversion_refusal(const CLI::App& app, const CLI::ConversionError& e) {
  static constexpr std::string_view prefix = "Could not convert: ";
  const std::string_view what = e.what();
  if (what.substr(0, prefix.size()) != prefix) return {};
  const std::string_view rest = what.substr(prefix.size());
  const size_t eq = rest.find(" = ");
  if (eq == std::string_view::npos) return {};
  const std::string name(rest.substr(0, eq)), text(rest.substr(eq + 3));
  const CLI::Option* option = find_option(app, name);
  if (!option) return {};
  const std::string type = read_as(*option);
  if (type == "INT" || type == "UINT") {
    // CLI11 keeps whatever strtoll / strtoull make of decimal text for a 64-bit flag (misread_number
    // checks those): decimal text it refused was refused by a 32-bit flag.
    const auto refuse = [&](const std::string& value) {
      if (!written_in_decimal(value)) return not_decimal(name, value);
      return type == "UINT" ? out_of_range<uint32_t>(name, value) : out_of_range<int32_t>(name, value);
    };
    // A flag of several values (--chunk CX CY CZ) is reported with them joined by commas: name the one at fault.
    std::string_view rest = text;
    for (size_t comma = rest.find(','); comma != std::string_view::npos; comma = rest.find(',')) {
      const std::string value(rest.substr(0, comma));
      if (!(type == "UINT" ? reads_as_written<uint32_t>(value) : reads_as_written<int32_t>(value))) return refuse(value);
      rest.remove_prefix(comma + 1);
    }
    return refuse(std::string(rest));
  }
  if (type == "FLOAT") return cat(name, " must be a number, got ", text);
  return {};
}

}  // namespace chungs::app
