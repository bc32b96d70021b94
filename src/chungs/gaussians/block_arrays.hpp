// BlockArrays: the 19 arrays of a GaussianBlock as pointers in one fixed order, so that memory that
// is not a GaussianBlock (the host buffers for chunks in flight, residency/host_block_pool.hpp) goes
// through the chunk codec and the Gaussian pools like one, without a copy into vectors.
//
// Order: params, Adam first moment, Adam second moment (each: mean, log_scale, rotation, opacity,
// sh), then adam_steps, created_by_keyframe, created_at_step, lr_position_factor. Array a holds
// kBlockArrayWidths[a] 4-byte values per Gaussian: floats, except the uint32 words 15-17.
// A view: it owns nothing, and holds as many Gaussians as `count` says.
#pragma once
#include <array>
#include <cstddef>
#include <type_traits>

#include "chungs/gaussians/gaussian_block.hpp"

namespace chungs {

constexpr int kBlockArrays = 19;
constexpr int kBlockArraysPerGroup = 5;  // params, m, v: mean, log_scale, rotation, opacity, sh
constexpr int kBlockGroupSh = 4;         // the sh array's place within a group
constexpr int kBlockFirstWord = 15;      // arrays 15-17 are uint32, 18 is float again
constexpr std::array<int, kBlockArrays> kBlockArrayWidths = {3, 3, 4, 1, kShFloats, 3, 3, 4, 1, kShFloats,
                                                             3, 3, 4, 1, kShFloats, 1, 1, 1, 1};

template <bool Const>
struct BlockArraysOf {
  using Pointer = std::conditional_t<Const, const void*, void*>;
  size_t count = 0;
  int sh_degree = kMaxShDegree;
  std::array<Pointer, kBlockArrays> data{};

  BlockArraysOf() = default;
  // A mutable view passes where a read-only one is wanted.
  // (A template, so that it never stands in for the copy constructor of the mutable one.)
  template <bool C = Const>
  requires C BlockArraysOf(const BlockArraysOf<false>& o) : count(o.count), sh_degree(o.sh_degree) {
    for (int a = 0; a < kBlockArrays; ++a) data[size_t(a)] = o.data[size_t(a)];
  }
  size_t values(int a) const { return count * size_t(kBlockArrayWidths[size_t(a)]); }
  size_t bytes(int a) const { return 4 * values(a); }
};
using BlockArrays = BlockArraysOf<false>;
using ConstBlockArrays = BlockArraysOf<true>;

// The arrays of a block, count = block.size(). Validate a block of unknown origin first: a view
// trusts its count.
BlockArrays block_arrays(GaussianBlock& block);
ConstBlockArrays block_arrays(const GaussianBlock& block);

// Bytes that the arrays of `count` Gaussians take laid out one after another, each array starting
// on a 16-byte boundary (for vector loads), and where laid_out_arrays puts them.
size_t laid_out_bytes(size_t count);
BlockArrays laid_out_arrays(void* base, size_t count, int sh_degree);

// The view of Gaussians [first, count) of `a`.
BlockArrays offset_arrays(const BlockArrays& a, size_t first);

// Copies Gaussians [first, first + n) of `from` to Gaussians [0, n) of `to` (to.count >= n).
void copy_gaussians(const ConstBlockArrays& from, size_t first, size_t n, const BlockArrays& to);

}  // namespace chungs
