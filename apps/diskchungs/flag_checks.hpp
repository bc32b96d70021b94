// Numbers given on the command line are checked where they are read: a value out of range is refused
// with the flag named, never replaced by a default; a flag not given leaves the setting alone.
#pragma once
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/store/chunk_id.hpp"
#include "command.hpp"

namespace chungs::app {

// False also where `app` has no such flag, so checks shared by sibling commands may ask for any.
inline bool given(const CLI::App& app, const char* flag) {
  const CLI::Option* option = app.get_option_no_throw(flag);
  return option && option->count() > 0;
}

// Throws Error "FLAG must be WHAT, got VALUE" unless ok.
template <class T>
void require_flag(bool ok, const char* flag, const std::string& what, const T& value) {
  if (!ok) fail(flag, " must be ", what, ", got ", value);
}

// run's and demo's --chunk-size: within the range a map's chunks may have (chunk_id.hpp), so that the
// chunk ids of the scene cannot run out in the middle of a run.
inline void require_chunk_size_flag(double metres) {
  require_flag(metres >= kMinChunkSize && metres <= kMaxChunkSize, "--chunk-size",
               cat("in [", kMinChunkSize, ", ", kMaxChunkSize, "] metres"), metres);
}

}  // namespace chungs::app
