#include "chungs/gaussians/gaussian_block.hpp"

#include "chungs/common/error.hpp"

namespace chungs {

namespace {
template <typename V>
void append_n(V& dst, const V& src, size_t i, size_t n) {
  dst.insert(dst.end(), src.begin() + i * n, src.begin() + (i + 1) * n);
}
template <typename V>
void append_range_n(V& dst, const V& src, size_t first, size_t count, size_t n) {
  dst.insert(dst.end(), src.begin() + first * n, src.begin() + (first + count) * n);
}
template <typename V>
void move_last_to(V& v, size_t i, size_t n) {
  size_t last = v.size() / n - 1;
  if (i != last)
    for (size_t k = 0; k < n; ++k) v[i * n + k] = v[last * n + k];
  v.resize(last * n);
}
}  // namespace

void GaussianParams::resize(size_t n) {
  mean.resize(3 * n);
  log_scale.resize(3 * n);
  rotation.resize(4 * n);
  opacity.resize(n);
  sh.resize(size_t(kShFloats) * n);
}

void GaussianParams::reserve(size_t n) {
  mean.reserve(3 * n);
  log_scale.reserve(3 * n);
  rotation.reserve(4 * n);
  opacity.reserve(n);
  sh.reserve(size_t(kShFloats) * n);
}

void GaussianParams::append(const GaussianParams& o, size_t i) {
  append_n(mean, o.mean, i, 3);
  append_n(log_scale, o.log_scale, i, 3);
  append_n(rotation, o.rotation, i, 4);
  append_n(opacity, o.opacity, i, 1);
  append_n(sh, o.sh, i, kShFloats);
}

void GaussianParams::append_range(const GaussianParams& o, size_t first, size_t n) {
  append_range_n(mean, o.mean, first, n, 3);
  append_range_n(log_scale, o.log_scale, first, n, 3);
  append_range_n(rotation, o.rotation, first, n, 4);
  append_range_n(opacity, o.opacity, first, n, 1);
  append_range_n(sh, o.sh, first, n, kShFloats);
}

void GaussianParams::swap_remove(size_t i) {
  move_last_to(mean, i, 3);
  move_last_to(log_scale, i, 3);
  move_last_to(rotation, i, 4);
  move_last_to(opacity, i, 1);
  move_last_to(sh, i, kShFloats);
}

void GaussianBlock::resize(size_t n) {
  params.resize(n);
  adam_m.resize(n);
  adam_v.resize(n);
  adam_steps.resize(n);
  created_by_keyframe.resize(n);
  created_at_step.resize(n);
  lr_position_factor.resize(n, 1.0f);
}

void GaussianBlock::reserve(size_t n) {
  params.reserve(n);
  adam_m.reserve(n);
  adam_v.reserve(n);
  adam_steps.reserve(n);
  created_by_keyframe.reserve(n);
  created_at_step.reserve(n);
  lr_position_factor.reserve(n);
}

void GaussianBlock::append(const GaussianBlock& o, size_t i) {
  params.append(o.params, i);
  adam_m.append(o.adam_m, i);
  adam_v.append(o.adam_v, i);
  append_n(adam_steps, o.adam_steps, i, 1);
  append_n(created_by_keyframe, o.created_by_keyframe, i, 1);
  append_n(created_at_step, o.created_at_step, i, 1);
  append_n(lr_position_factor, o.lr_position_factor, i, 1);
}

void GaussianBlock::append_range(const GaussianBlock& o, size_t first, size_t n) {
  params.append_range(o.params, first, n);
  adam_m.append_range(o.adam_m, first, n);
  adam_v.append_range(o.adam_v, first, n);
  append_range_n(adam_steps, o.adam_steps, first, n, 1);
  append_range_n(created_by_keyframe, o.created_by_keyframe, first, n, 1);
  append_range_n(created_at_step, o.created_at_step, first, n, 1);
  append_range_n(lr_position_factor, o.lr_position_factor, first, n, 1);
}

void GaussianBlock::swap_remove(size_t i) {
  params.swap_remove(i);
  adam_m.swap_remove(i);
  adam_v.swap_remove(i);
  move_last_to(adam_steps, i, 1);
  move_last_to(created_by_keyframe, i, 1);
  move_last_to(created_at_step, i, 1);
  move_last_to(lr_position_factor, i, 1);
}

void GaussianBlock::validate(const char* what) const {
  if (sh_degree < 0 || sh_degree > kMaxShDegree) fail(what, ": SH degree ", sh_degree, " is out of range 0..3");
  const size_t n = size();
  auto check = [&](const GaussianParams& p, const char* name) {
    if (p.mean.size() != 3 * n || p.log_scale.size() != 3 * n || p.rotation.size() != 4 * n ||
        p.opacity.size() != n || p.sh.size() != size_t(kShFloats) * n)
      fail(what, ": ", name, " arrays disagree with the Gaussian count ", n);
  };
  check(params, "parameter");
  check(adam_m, "Adam first-moment");
  check(adam_v, "Adam second-moment");
  if (adam_steps.size() != n || created_by_keyframe.size() != n || created_at_step.size() != n ||
      lr_position_factor.size() != n)
    fail(what, ": bookkeeping arrays disagree with the Gaussian count ", n);
}

}  // namespace chungs
