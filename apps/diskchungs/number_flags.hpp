// Numbers typed on the command line, read as written or refused. CLI11 reads whole numbers with strtoll /
// strtoull in base 0 and keeps what those return, so a number too large for 64 bits became the largest
// one (`--budget 99999999999999999999` was then refused as 9223372036854775807, `synth --seed` took it
// silently), "-1" given to an unsigned flag became 2^64 - 1, and a leading zero made it octal (`010` is 8).
// It read an empty text as 0 for a decimal flag (`--fill-depth ""` was "skip the sky") and took hex
// (`--length-m 0x10` was 16).
#pragma once
#include <CLI/CLI.hpp>
#include <string>

namespace chungs::app {

// "FLAG must be a whole number ... written in decimal ..., got TEXT" for the first whole-number flag
// given to `app` or to a subcommand it parsed whose text is not read as written, and "FLAG must be a
// number written in decimal, got TEXT" for a decimal flag given an empty or hexadecimal text; empty when
// none. (nan and inf pass here: each flag's range names them.)
std::string misread_number(const CLI::App& app);

// CLI11's own refusal of a value its flag's type cannot hold ("Could not convert: --iterations =
// 3000000000") in the words above: the flag, what it takes (a whole number within 32 or 64 bits, or a
// number) and the text given; empty when `e` is not such a refusal of a flag of `app`'s tree.
std::string conversion_refusal(const CLI::App& app, const CLI::ConversionError& e);

}  // namespace chungs::app
