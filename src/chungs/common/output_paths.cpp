#include "chungs/common/output_paths.hpp"

#include <cstring>
#include <fstream>

#include "chungs/common/error.hpp"

namespace chungs {

namespace {

// Absolute, links and ".." resolved as far as the path exists, without a trailing separator.
std::filesystem::path resolved(const std::filesystem::path& p) {
  std::error_code ec;
  std::filesystem::path r = std::filesystem::weakly_canonical(std::filesystem::absolute(p, ec), ec);
  if (ec) r = std::filesystem::absolute(p).lexically_normal();
  return r.has_filename() || !r.has_relative_path() ? r : r.parent_path();
}

}  // namespace

bool lies_within(const std::filesystem::path& path, const std::filesystem::path& folder) {
  const std::filesystem::path p = resolved(path), f = resolved(folder);
  auto pi = p.begin();
  for (auto fi = f.begin(); fi != f.end(); ++fi, ++pi)
    if (pi == p.end() || *pi != *fi) return false;
  return true;
}

void refuse_output_over_input(const std::filesystem::path& output, const std::string& output_flag,
                              const std::filesystem::path& input, const std::string& input_flag) {
  std::error_code ec;
  // equivalent() sees hard links too, but is false where either is absent: the resolved paths decide then.
  if (std::filesystem::equivalent(output, input, ec) || resolved(output) == resolved(input))
    fail(output.string(), ": ", output_flag, " would replace the file ", input_flag, " reads (", input.string(),
         "); give another path");
}

void refuse_replacing_other_than_png(const std::filesystem::path& file, const std::string& flag) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return;  // absent, or a folder that the writer refuses
  static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  unsigned char head[8] = {};
  std::ifstream in(file, std::ios::binary);
  in.read(reinterpret_cast<char*>(head), sizeof head);
  if (in.gcount() != sizeof head || std::memcmp(head, signature, sizeof head) != 0)
    fail(file.string(), ": exists and is not a PNG image; ", flag, " does not replace it (give another path)");
}

}  // namespace chungs
