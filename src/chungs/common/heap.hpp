// The host heap of a long run. Chunks in flight (queued writes, read-ahead, checkpoint copies) were
// allocated and freed by different threads in bursts; with glibc's defaults each thread's arena
// grew to its own peak the first time its queue filled, and freed pages went back and forth, so host
// RSS rose in steps of 50-125 MB minutes after the budget was reached (bench/README.md, the 10 km
// drive). keep_heap_for_reuse makes such a peak resident once, at the start, and has the allocator
// keep and reuse it. The mapping run now keeps chunks in flight out of the heap altogether
// (residency/host_block_pool.hpp: a reserve in the heap was taken by what the map held before the
// budget was full) and calls it for the thresholds alone.
#pragma once
#include <cstddef>

namespace chungs {

// glibc: allocations up to 32 MB served from the heap and freed memory never trimmed; then
// `reserve_bytes` allocated in pieces, touched and freed, so the heap holds them from the start.
// The process's RSS then stays at its peak instead of following the queues. It works best with one
// arena for every thread (the CLI sets that at start, so that a block freed by the I/O thread serves
// the optimiser's next one). GLIBC_TUNABLES in the environment keeps its say over the thresholds.
// A no-op elsewhere.
void keep_heap_for_reuse(size_t reserve_bytes);

}  // namespace chungs
