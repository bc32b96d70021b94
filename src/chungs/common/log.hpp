// The one logger: messages go to stderr with a level tag; --quiet keeps only warnings and errors.
#pragma once
#include <string>

#include "chungs/common/error.hpp"

namespace chungs::log {

enum class Level { Debug = 0, Info = 1, Warn = 2, Error = 3, Off = 4 };

void set_level(Level level);
Level level();
bool enabled(Level level);
void write(Level level, const std::string& msg);

template <typename... Args>
void debug(const Args&... a) {
  if (enabled(Level::Debug)) write(Level::Debug, cat(a...));
}
template <typename... Args>
void info(const Args&... a) {
  if (enabled(Level::Info)) write(Level::Info, cat(a...));
}
template <typename... Args>
void warn(const Args&... a) {
  if (enabled(Level::Warn)) write(Level::Warn, cat(a...));
}
template <typename... Args>
void error(const Args&... a) {
  if (enabled(Level::Error)) write(Level::Error, cat(a...));
}

}  // namespace chungs::log
