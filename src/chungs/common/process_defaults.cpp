// A mapping run holds a bounded working set on the host, but its buffers come and go in sizes that
// never repeat exactly (chunks in flight to and from disk, keyframe images, stereo matching) and on
// many threads. glibc malloc gives each thread that allocates concurrently an arena of its own (up
// to 8 per core) and frees a block back into the arena it came from, so each arena grows to its own
// peak and host memory steps up although what is live stays bounded. One arena lets a block freed by
// the I/O thread serve the optimiser's next one; the chunks in flight live in a pool of their own,
// made resident at the start (residency/host_block_pool.hpp), and freed memory is kept
// (common/heap.hpp). 10 km drive on an H100: +3.8 % / -0.0 % around the plateau once the budget was
// reached, no slower (bench/README.md). MALLOC_ARENA_MAX or GLIBC_TUNABLES in the environment still
// decide where set.
//
// OpenCV: nothing here uses OpenCL; left on, OpenCV probes the platform at its first call, which cost
// the tracker's first frame 30-280 ms on a GPU host (bench/README.md). The environment may still say.
#include "chungs/common/process_defaults.hpp"

#include <malloc.h>

#include <cstdlib>

namespace chungs {

namespace {
constexpr int kArenas = 1;
bool g_limited = false;
}  // namespace

void set_process_defaults() {
  if (!std::getenv("MALLOC_ARENA_MAX") && !std::getenv("GLIBC_TUNABLES"))
    g_limited = mallopt(M_ARENA_MAX, kArenas) == 1;
  setenv("OPENCV_OPENCL_DEVICE", "disabled", 0);
}

std::string allocator_description() {
  if (g_limited) return "glibc malloc, " + std::to_string(kArenas) + (kArenas == 1 ? " arena" : " arenas");
  if (const char* v = std::getenv("MALLOC_ARENA_MAX"))
    return std::string("glibc malloc, MALLOC_ARENA_MAX=") + v;
  if (const char* v = std::getenv("GLIBC_TUNABLES")) return std::string("glibc malloc, GLIBC_TUNABLES=") + v;
  return "glibc malloc";
}

}  // namespace chungs
