// Writing many chunks at a checkpoint on several threads: one chunk save is bound by one core
// (checksum, copy into the page cache, half-precision encoding) well below what the disk takes.
#pragma once
#include <functional>
#include <vector>

#include "chungs/store/chunk_store.hpp"

namespace chungs {

// Saves the chunks `ids` on `threads` writer threads. The caller's thread produces each block in
// turn (produce(k, block) fills block k, e.g. gathered from a GPU pool that only this thread may
// touch) while the writers save the earlier ones; at most 2 x threads blocks wait in memory.
// Rethrows the first failure once every thread has stopped (some chunks may be saved by then).
void save_chunks_in_parallel(ChunkStore& store, const std::vector<ChunkId>& ids,
                             const std::function<void(size_t, GaussianBlock&)>& produce, int threads);

}  // namespace chungs
