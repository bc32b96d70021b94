#include "chungs/common/heap.hpp"

#include <algorithm>
#include <cstdlib>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace chungs {

void keep_heap_for_reuse(size_t reserve_bytes) {
#if defined(__GLIBC__)
  constexpr size_t kPiece = size_t(16) << 20;  // below the mmap threshold: served by, and kept in, the heap
  if (!std::getenv("GLIBC_TUNABLES")) {
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 0x7fffffff);
  }
  std::vector<void*> pieces;
  for (size_t done = 0; done < reserve_bytes; done += kPiece) {
    const size_t n = std::min(kPiece, reserve_bytes - done);
    void* p = std::malloc(n);
    if (!p) break;  // the reserve is an optimisation: without it the run goes on as before
    // Written page by page through a volatile pointer: a memset before free may be optimised away.
    volatile char* bytes = static_cast<volatile char*>(p);
    for (size_t i = 0; i < n; i += 4096) bytes[i] = 0;
    pieces.push_back(p);
  }
  for (void* p : pieces) std::free(p);
#else
  (void)reserve_bytes;
#endif
}

}  // namespace chungs
