// What every fuzz target shares: the readers take paths, so each input is written to a file in one
// temporary folder per process (made once, removed at exit), and the project's one error type is a
// clean refusal while anything else (crash, sanitizer report, other exception) is a finding.
#pragma once
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <utility>

#include "chungs/common/error.hpp"

namespace chungs::fuzz {

namespace fs = std::filesystem;

// The folder lives for the whole process: making and removing one per input would cost more than
// most of the parsers take.
class TempFolder {
 public:
  TempFolder() {
    std::string pattern = (fs::temp_directory_path() / "chungs-fuzz-XXXXXX").string();
    if (!mkdtemp(pattern.data())) std::abort();
    dir_ = pattern;
  }
  ~TempFolder() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  const fs::path& dir() const { return dir_; }

  // Replaces `name` (a path relative to the folder; parents are made) with the bytes.
  fs::path write(const fs::path& name, const void* data, size_t size) const {
    const fs::path file = dir_ / name;
    fs::create_directories(file.parent_path());
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(static_cast<const char*>(data), std::streamsize(size));
    out.close();
    if (!out) std::abort();
    return file;
  }
  fs::path write(const fs::path& name, std::string_view text) const { return write(name, text.data(), text.size()); }

 private:
  fs::path dir_;
};

inline const TempFolder& temp_folder() {
  static const TempFolder folder;
  return folder;
}

// Runs one parse. An Error is the documented refusal of bad input, but it must name what is at
// fault (`culprit`: the file's path, or what any path shares), or the user cannot act on it.
template <typename Parse>
void refusing(std::string_view culprit, Parse&& parse) {
  try {
    parse();
  } catch (const Error& e) {
    if (std::string_view(e.what()).find(culprit) == std::string_view::npos) {
      std::fprintf(stderr, "error does not name %.*s: %s\n", int(culprit.size()), culprit.data(), e.what());
      std::abort();
    }
  }
}

template <typename Parse>
void refusing(const fs::path& file, Parse&& parse) {
  refusing(std::string_view(file.native()), std::forward<Parse>(parse));
}

}  // namespace chungs::fuzz
