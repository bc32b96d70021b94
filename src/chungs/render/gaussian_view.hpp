// Non-owning views of Gaussian parameter arrays (the GaussianParams layout) and the gradient arrays
// the backward pass fills. The renderer reads the pool's arrays in place through a view plus a list
// of slot indices: nothing is copied. The scalar type is a template parameter so the gradient tests
// can run the same code in float64.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/gaussians/gaussian_block.hpp"

namespace chungs {

// Per slot s: mean[3s..], log_scale[3s..], rotation[4s..] (w,x,y,z), opacity[s] (logit),
// sh[48s + 3k + c]. `capacity` is the number of slots the arrays hold; indices must be below it.
template <typename T>
struct GaussianArrays {
  const T* mean = nullptr;
  const T* log_scale = nullptr;
  const T* rotation = nullptr;
  const T* opacity = nullptr;
  const T* sh = nullptr;
  size_t capacity = 0;
};

template <typename T>
struct GaussianArraysMut {
  T* mean = nullptr;
  T* log_scale = nullptr;
  T* rotation = nullptr;
  T* opacity = nullptr;
  T* sh = nullptr;
  size_t capacity = 0;

  operator GaussianArrays<T>() const { return {mean, log_scale, rotation, opacity, sh, capacity}; }
};

// Gradients of a loss with respect to the parameters of the rendered Gaussians. Compact: entry j
// belongs to the j-th index of the list that was rendered (not to slot ids[j]), so the buffers scale
// with the visible set, not with the pool. Same per-Gaussian layout as GaussianParams.
template <typename T>
struct GaussianGrads {
  std::vector<T> mean, log_scale, rotation, opacity, sh;

  size_t size() const { return opacity.size(); }
  void resize(size_t n) {
    mean.resize(3 * n);
    log_scale.resize(3 * n);
    rotation.resize(4 * n);
    opacity.resize(n);
    sh.resize(size_t(kShFloats) * n);
  }
};

inline GaussianArrays<float> view_of(const GaussianParams& p) {
  return {p.mean.data(), p.log_scale.data(), p.rotation.data(), p.opacity.data(), p.sh.data(), p.size()};
}

inline GaussianArraysMut<float> mut_view_of(GaussianParams& p) {
  return {p.mean.data(), p.log_scale.data(), p.rotation.data(), p.opacity.data(), p.sh.data(), p.size()};
}

// A view must cover every index of a render; throws Error naming the first bad index otherwise.
template <typename T>
void check_indices(const GaussianArrays<T>& g, const uint32_t* ids, size_t n, const char* what) {
  if (n == 0) return;
  if (!g.mean || !g.log_scale || !g.rotation || !g.opacity || !g.sh)
    fail(what, ": Gaussian arrays are missing (null pointer) for ", n, " indices");
  for (size_t j = 0; j < n; ++j)
    if (ids[j] >= g.capacity)
      fail(what, ": index ", j, " names slot ", ids[j], " but the arrays hold ", g.capacity, " slots");
}

}  // namespace chungs
