// MappedAllocator: memory straight from the system (mmap), given back when freed (munmap), for the
// large arrays of a phase that comes once, such as the refinement's plan over every keyframe's view,
// and for the buffers of threads that live for one task (a checkpoint's writers).
// A mapping run keeps freed heap for reuse (heap.hpp), so arrays of a few MB from the heap stay in
// its RSS after the phase; and growing by doubling, they needed fresh heap beyond the holes that
// smaller blocks left: the plan of a 5 km CPU drive raised RSS by 10 MB that stayed (bench/README.md,
// issue 19). Page faults on first touch are the price: for arrays used by many short-lived
// allocations, the heap is the better home.
#pragma once
#include <sys/mman.h>

#include <cstddef>
#include <new>
#include <vector>

namespace chungs {

template <class T>
struct MappedAllocator {
  using value_type = T;
  MappedAllocator() = default;
  template <class U>
  MappedAllocator(const MappedAllocator<U>&) {}
  T* allocate(size_t n) {
    if (n == 0) return nullptr;  // mmap refuses an empty mapping
    if (n > size_t(-1) / sizeof(T)) throw std::bad_alloc();
    void* p = ::mmap(nullptr, n * sizeof(T), PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    return static_cast<T*>(p);
  }
  void deallocate(T* p, size_t n) {
    if (p) ::munmap(p, n * sizeof(T));
  }
  template <class U>
  bool operator==(const MappedAllocator<U>&) const {
    return true;
  }
};

template <class T>
using MappedVector = std::vector<T, MappedAllocator<T>>;

}  // namespace chungs
