// A mapping run holds a bounded working set on the host, but its buffers come and go in sizes that
// never repeat exactly (chunks in flight to and from disk, keyframe images, stereo matching) and on
// many threads. glibc malloc gives each thread that allocates concurrently an arena of its own (up
// to 8 per core) and frees a block back into the arena it came from; over a long drive the arenas
// fragment independently and host memory creeps up although what is live stays bounded. Two arenas
// keep RSS level (10 km drives on an H100: at most +4.9 % above the plateau once the budget was
// reached, where the default arenas dipped to -21 %, at no cost in speed; bench/README.md). MALLOC_ARENA_MAX or
// GLIBC_TUNABLES in the environment still decide where set.
#include "allocator.hpp"

#include <malloc.h>

#include <cstdlib>

namespace chungs::app {

namespace {
constexpr int kArenas = 2;
bool g_limited = false;
}  // namespace

void limit_allocator_arenas() {
  if (std::getenv("MALLOC_ARENA_MAX") || std::getenv("GLIBC_TUNABLES")) return;
  g_limited = mallopt(M_ARENA_MAX, kArenas) == 1;
}

std::string allocator_description() {
  if (g_limited) return "glibc malloc, " + std::to_string(kArenas) + " arenas";
  if (const char* v = std::getenv("MALLOC_ARENA_MAX"))
    return std::string("glibc malloc, MALLOC_ARENA_MAX=") + v;
  if (const char* v = std::getenv("GLIBC_TUNABLES")) return std::string("glibc malloc, GLIBC_TUNABLES=") + v;
  return "glibc malloc";
}

}  // namespace chungs::app
