// The map folder's manifest (store/manifest.hpp). The end line's checksum is recomputed over the
// mutated body, so the line parser behind it is reached. A manifest that reads must also write
// back and read again to the same text: a checkpoint rewrites what --resume read.
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "chungs/store/checksum.hpp"
#include "chungs/store/manifest.hpp"
#include "fuzz_input.hpp"

namespace {

std::string reseal(const std::string& text) {
  const size_t at = text.rfind("\nend ");
  if (at == std::string::npos) return text;
  const std::string body = text.substr(0, at + 1);
  std::istringstream end_line(text.substr(at + 1));
  std::string tag, count;
  end_line >> tag >> count;
  char sum[20];
  std::snprintf(sum, sizeof sum, "%016" PRIx64, chungs::xxh64(body.data(), body.size()));
  return body + "end " + count + ' ' + sum + '\n';
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text = reseal(std::string(reinterpret_cast<const char*>(data), size));
  const auto file = chungs::fuzz::temp_folder().write("manifest.txt", text);
  chungs::fuzz::refusing(file, [&] {
    const chungs::Manifest m = chungs::Manifest::read(file);
    const std::string once = m.serialize();
    const std::string twice = chungs::Manifest::parse(once, file).serialize();
    if (once != twice) {
      std::fprintf(stderr, "manifest does not read back as written:\n%s---\n%s", once.c_str(), twice.c_str());
      std::abort();
    }
  });
  return 0;
}
