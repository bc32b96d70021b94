#include "chungs/common/heap.hpp"

#include <cstdio>

#if defined(__GLIBC__)
#include <malloc.h>
#include <unistd.h>
#endif

namespace chungs {

namespace {

// Resident pages of this process (/proc/self/statm), 0 where unknown.
size_t resident_bytes() {
#if defined(__GLIBC__)
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  unsigned long size = 0, resident = 0;
  const int n = std::fscanf(f, "%lu %lu", &size, &resident);
  std::fclose(f);
  return n == 2 ? size_t(resident) * size_t(sysconf(_SC_PAGESIZE)) : 0;
#else
  return 0;
#endif
}

}  // namespace

size_t release_free_heap() {
#if defined(__GLIBC__)
  const size_t before = resident_bytes();
  malloc_trim(0);
  const size_t after = resident_bytes();
  return before > after ? before - after : 0;
#else
  return 0;
#endif
}

}  // namespace chungs
