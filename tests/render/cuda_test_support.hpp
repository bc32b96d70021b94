// Helpers for the CUDA parity tests: skip without a device, upload scenes, compare arrays.
#pragma once
#ifdef CHUNGS_WITH_CUDA
#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "chungs/cuda/devices.hpp"
#include "chungs/render/cuda/device_buffer.hpp"
#include "chungs/render/gaussian_view.hpp"

namespace chungs::test {

// A scene's float arrays in device memory.
struct DeviceScene {
  cuda::DeviceArray<float> mean, log_scale, rotation, opacity, sh;
  template <typename Arrays>
  explicit DeviceScene(const Arrays& a)
      : mean(a.mean), log_scale(a.log_scale), rotation(a.rotation), opacity(a.opacity), sh(a.sh) {}
  GaussianArrays<float> view() const {
    return {mean.data(), log_scale.data(), rotation.data(), opacity.data(), sh.data(), opacity.size()};
  }
};

// ||a - b|| / ||b|| over all elements (b in any precision).
template <typename A, typename B>
double rel_error(const std::vector<A>& a, const std::vector<B>& b) {
  EXPECT_EQ(a.size(), b.size());
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const double d = double(a[i]) - double(b[i]);
    if (!std::isfinite(double(a[i]))) return INFINITY;
    num += d * d;
    den += double(b[i]) * double(b[i]);
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

}  // namespace chungs::test
#endif
