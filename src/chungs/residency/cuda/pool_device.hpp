// Internal: device memory and transfers of the CUDA Gaussian pool, as plain C++17 (the pool class
// itself is C++20 and lives in gaussian_pool.cpp). Every array holds 4-byte elements (float or
// uint32), `width` per slot.
#pragma once
#include <cstddef>
#include <cstdint>

namespace chungs::cuda::detail {

struct PoolDevice;  // arrays, a non-blocking copy stream, pinned staging buffers, events

PoolDevice* pool_device_create(size_t capacity, const int* widths, int count);
void pool_device_destroy(PoolDevice* d);
void* pool_device_array(PoolDevice* d, int array);
// Replaces every array by one of `capacity` slots holding the old slots' contents, after all work
// queued on the default stream and the pool's stream; the old pointers are invalid afterwards, also
// when it throws (device memory short): then some arrays may have grown, each with its contents.
void pool_device_grow(PoolDevice* d, size_t capacity);

// Gaussians per transfer: larger batches move in pieces of this many through fixed staging buffers.
size_t pool_device_piece();
// Host blocks laid end to end: block b holds `count` Gaussians, array a at data[a] (width_a
// elements each). Written through by a gather only.
struct HostArrays {
  const void* const* data;
  size_t count;
};
// Copies Gaussian i of the blocks laid end to end into slots[i] of every array (n in all). Returns
// once the host data is staged (the caller may reuse it); the upload and the scatter run on the
// pool's stream after the work already queued on the default stream (which may still read those slots).
void pool_device_scatter(PoolDevice* d, const HostArrays* blocks, size_t block_count, const uint32_t* slots, size_t n);
// Copies slots[i] of every array into Gaussian i of the blocks laid end to end, after the work
// queued on the default stream (the optimiser's updates); returns when the data is on the host.
void pool_device_gather(PoolDevice* d, const HostArrays* blocks, size_t block_count, const uint32_t* slots, size_t n);
// Makes work queued later on the default stream wait for the uploads queued so far (no host wait).
void pool_device_wait_uploads(PoolDevice* d);
// Host wait for all of the pool's transfers.
void pool_device_synchronize(PoolDevice* d);

}  // namespace chungs::cuda::detail
