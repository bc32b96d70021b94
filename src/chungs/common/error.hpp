// One exception type for every input or runtime error. The message names the file, frame or value
// at fault; the CLI prints it as one line and exits non-zero.
#pragma once
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>

namespace chungs {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

// Concatenates any streamable arguments into a message: fail("bad value ", v, " in ", path).
template <typename... Args>
std::string cat(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}

template <typename... Args>
[[noreturn]] void fail(const Args&... args) {
  throw Error(cat(args...));
}

// Throws "PATH: does not exist" (or "is not a directory") when a required input is missing.
void require_file(const std::filesystem::path& p, const std::string& what = "file");
void require_dir(const std::filesystem::path& p, const std::string& what = "folder");
// Makes the folders an output file goes into; throws naming the file and the folder when they cannot be
// made (a file where a folder should be) or when the file's path is a folder. Commands call it before
// their work, so that a bad --out does not cost a run's minutes.
void prepare_output_file(const std::filesystem::path& p, const std::string& what = "file");

}  // namespace chungs
