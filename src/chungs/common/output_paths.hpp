// Where a command's outputs may go: never over what it reads. A path typed into the wrong flag (an
// output named like an input, an output folder holding an input) must be refused, not overwritten.
#pragma once
#include <filesystem>
#include <string>

namespace chungs {

// Whether `path` is `folder` or lies below it, as both resolve on disk (links, "..", relative paths);
// neither need exist.
bool lies_within(const std::filesystem::path& path, const std::filesystem::path& folder);

// Throws "OUTPUT: OUTPUT_FLAG would replace the file INPUT_FLAG reads (INPUT); give another path" when
// writing `output` would overwrite the input file `input`, under any name (links, hard links).
void refuse_output_over_input(const std::filesystem::path& output, const std::string& output_flag,
                              const std::filesystem::path& input, const std::string& input_flag);

// Throws "FILE: exists and is not a PNG image; FLAG does not replace it" for an existing file without the
// PNG signature: a PNG output (a plot) may replace an earlier plot, never a file of another kind.
void refuse_replacing_other_than_png(const std::filesystem::path& file, const std::string& flag);

}  // namespace chungs
