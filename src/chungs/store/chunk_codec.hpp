// How a GaussianBlock's arrays are laid out in a chunk file's payload, and their optional
// half-precision encodings:
//  - half moments: each Adam moment array as a float32 power-of-two scale followed by binary16
//    values of x / scale (the scale maps the array's largest magnitude just under 2^15, so values
//    down to 2^-29 of it keep 11 significant bits). The second moment is stored as
//    sign(v) sqrt(|v|): Adam divides by sqrt(v), so this halves the dynamic range that has to
//    fit and gives sqrt(v) the relative precision the step needs; a non-zero value never
//    decodes to zero (that would blow the step up).
//  - half SH rest: the colour's higher SH coefficients (all but the 3 DC values per Gaussian)
//    the same way, with the DC values kept as float32.
// Parameters other than SH rest and the bookkeeping words stay float32/uint32 bit-exact.
#pragma once
#include <cstdint>
#include <functional>

#include "chungs/gaussians/block_arrays.hpp"

namespace chungs {

constexpr uint32_t kChunkFlagHalfMoments = 1u << 2;
constexpr uint32_t kChunkFlagHalfShRest = 1u << 3;

// One stored array: its bytes and the element size the byte shuffle groups by (4 or 2).
struct PayloadArray {
  uint8_t* data;
  size_t bytes;
  int element_bytes;
};

// Payload bytes of `count` Gaussians under the given flags (before compression).
uint64_t chunk_payload_bytes(uint64_t count, uint32_t flags);

// The payload of `block` under `flags`, in file order, a piece at a time: emit(data, bytes) for each
// (it may not keep `data`). Arrays stored as they are come whole, straight from the block; converted
// ones through buffers of the calling thread of ~600 KB, reused from piece to piece, so a thread that
// writes chunks holds that much whatever their size.
void encode_payload(const ConstBlockArrays& block, uint32_t flags,
                    const std::function<void(const void*, size_t)>& emit);
// The reverse, into a block already sized: read(dst, bytes) fills dst with the payload's next bytes.
// The block holds the payload once it returns (partly, when read throws).
void decode_payload(const BlockArrays& block, uint32_t flags, const std::function<void(void*, size_t)>& read);

// The payload as zstd takes it with the byte shuffle: each stored array's elements by byte, all first
// bytes, then all second bytes, ... (elements of 4 bytes; of 2 for the halves, their scale being the
// array's first two elements), a piece at a time through buffers of the calling thread, as
// encode_payload. The stream is the one a whole-array shuffle makes, so files written either way
// read the same.
void encode_shuffled_payload(const ConstBlockArrays& block, uint32_t flags,
                             const std::function<void(const void*, size_t)>& emit);
// The reverse, into a block already sized. The first bytes of the halves wait in the memory of the
// values they belong to until their second bytes come, so no array is held twice.
void decode_shuffled_payload(const BlockArrays& block, uint32_t flags, const std::function<void(void*, size_t)>& read);

}  // namespace chungs
