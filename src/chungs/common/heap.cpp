#include "chungs/common/heap.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace chungs {

void release_free_heap() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

}  // namespace chungs
