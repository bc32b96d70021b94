#include "chungs/gaussians/block_arrays.hpp"

#include <cstdint>
#include <cstring>
#include <numeric>

#include "chungs/common/error.hpp"

namespace chungs {

static_assert(std::accumulate(kBlockArrayWidths.begin(), kBlockArrayWidths.end(), size_t(0)) * 4 ==
                  kBlockBytesPerGaussian,
              "the 19 arrays are the whole of a Gaussian's host bytes");

namespace {

constexpr size_t kAlign = 16;
size_t aligned(size_t bytes) { return (bytes + kAlign - 1) / kAlign * kAlign; }

template <typename Arrays, typename Block>
Arrays arrays_of(Block& b) {
  Arrays out;
  out.count = b.size();
  out.sh_degree = b.sh_degree;
  size_t a = 0;
  for (auto* p : {&b.params, &b.adam_m, &b.adam_v}) {
    out.data[a++] = p->mean.data();
    out.data[a++] = p->log_scale.data();
    out.data[a++] = p->rotation.data();
    out.data[a++] = p->opacity.data();
    out.data[a++] = p->sh.data();
  }
  out.data[a++] = b.adam_steps.data();
  out.data[a++] = b.created_by_keyframe.data();
  out.data[a++] = b.created_at_step.data();
  out.data[a++] = b.lr_position_factor.data();
  return out;
}

}  // namespace

BlockArrays block_arrays(GaussianBlock& block) { return arrays_of<BlockArrays>(block); }
ConstBlockArrays block_arrays(const GaussianBlock& block) { return arrays_of<ConstBlockArrays>(block); }

size_t laid_out_bytes(size_t count) {
  size_t bytes = 0;
  for (int w : kBlockArrayWidths) bytes += aligned(4 * size_t(w) * count);
  return bytes;
}

BlockArrays laid_out_arrays(void* base, size_t count, int sh_degree) {
  BlockArrays out;
  out.count = count;
  out.sh_degree = sh_degree;
  auto* at = static_cast<std::byte*>(base);
  for (int a = 0; a < kBlockArrays; ++a) {
    out.data[size_t(a)] = at;
    at += aligned(out.bytes(a));
  }
  return out;
}

BlockArrays offset_arrays(const BlockArrays& a, size_t first) {
  if (first > a.count) fail("offset_arrays: Gaussian ", first, " of ", a.count);
  BlockArrays out = a;
  out.count = a.count - first;
  for (int i = 0; i < kBlockArrays; ++i)
    out.data[size_t(i)] = static_cast<std::byte*>(a.data[size_t(i)]) + first * 4 * size_t(kBlockArrayWidths[size_t(i)]);
  return out;
}

void copy_gaussians(const ConstBlockArrays& from, size_t first, size_t n, const BlockArrays& to) {
  if (first + n > from.count || n > to.count)
    fail("copy_gaussians: Gaussians [", first, ", ", first + n, ") of ", from.count, " into ", to.count);
  if (n == 0) return;
  for (int a = 0; a < kBlockArrays; ++a) {
    const size_t w = 4 * size_t(kBlockArrayWidths[size_t(a)]);
    std::memcpy(to.data[size_t(a)], static_cast<const std::byte*>(from.data[size_t(a)]) + first * w, n * w);
  }
}

}  // namespace chungs
