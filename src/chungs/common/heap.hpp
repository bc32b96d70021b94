// Giving the allocator's free memory back to the system. Over a long drive the heap fragments:
// chunk blocks, keyframe images and per-step buffers of many sizes are freed by threads other than
// the ones that allocated them, and glibc keeps the free pages between live allocations, so host RSS
// creeps with distance while the live heap stays level (bench/README.md).
#pragma once

namespace chungs {

// Returns whole free pages of every allocator arena to the system (glibc's malloc_trim); a no-op
// elsewhere.
void release_free_heap();

}  // namespace chungs
