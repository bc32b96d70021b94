// Whole numbers typed on the command line, read as written or refused. CLI11 reads them with strtoll /
// strtoull in base 0 and keeps what those return, so a number too large for 64 bits became the largest
// one (`--budget 99999999999999999999` was then refused as 9223372036854775807, `synth --seed` took it
// silently), "-1" given to an unsigned flag became 2^64 - 1, and a leading zero made it octal (`010` is 8).
#pragma once
#include <CLI/CLI.hpp>
#include <string>

namespace chungs::app {

// "FLAG must be a whole number ... written in decimal ..., got TEXT" for the first whole-number flag
// given to `app` or to a subcommand it parsed whose text is not read as written; empty when none.
std::string misread_whole_number(const CLI::App& app);

// CLI11's own refusal of a value its flag's type cannot hold ("Could not convert: --iterations =
// 3000000000") in the words above: the flag, what it takes (a whole number within 32 or 64 bits, or a
// number) and the text given; empty when `e` is not such a refusal of a flag of `app`'s tree.
std::string conversion_refusal(const CLI::App& app, const CLI::ConversionError& e);

}  // namespace chungs::app
