#include "chungs/common/log.hpp"

#include <atomic>
#include <cstdio>
#include <mutex>

namespace chungs::log {

namespace {
std::atomic<Level> g_level{Level::Info};
std::mutex g_mutex;
const char* tag(Level l) {
  switch (l) {
    case Level::Debug: return "debug";
    case Level::Info: return "info";
    case Level::Warn: return "warning";
    case Level::Error: return "error";
    default: return "";
  }
}
}  // namespace

void set_level(Level level) { g_level = level; }
Level level() { return g_level; }
bool enabled(Level l) { return l >= g_level.load() && l != Level::Off; }

void write(Level l, const std::string& msg) {
  std::lock_guard lock(g_mutex);
  std::fprintf(stderr, "[%s] %s\n", tag(l), msg.c_str());
  std::fflush(stderr);
}

}  // namespace chungs::log
