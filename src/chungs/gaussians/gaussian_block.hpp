// GaussianBlock: a structure of arrays of 3D Gaussians with their Adam state and bookkeeping.
// The same layout is used by chunk files, the CPU pool and (as device arrays) the CUDA pool.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace chungs {

constexpr int kMaxShDegree = 3;
constexpr int kShCoeffs = 16;                // per colour channel at degree 3
constexpr int kShFloats = kShCoeffs * 3;     // 48 per Gaussian
constexpr int kParamFloats = 3 + 3 + 4 + 1 + kShFloats;  // 59 optimised floats per Gaussian

inline constexpr int sh_coeffs_for_degree(int degree) { return (degree + 1) * (degree + 1); }

// The optimised parameters, one array per kind. Per Gaussian i:
//   mean[3i..]       world position (metres)
//   log_scale[3i..]  natural log of the three standard deviations (metres)
//   rotation[4i..]   quaternion (w, x, y, z), not necessarily normalised
//   opacity[i]       logit of opacity
//   sh[48i..]        SH coefficients, coefficient-major: sh[48i + 3k + c] is coefficient k of
//                    channel c (k = 0 is DC). Degrees below 3 leave the higher k at zero.
struct GaussianParams {
  std::vector<float> mean, log_scale, rotation, opacity, sh;

  size_t size() const { return opacity.size(); }
  void resize(size_t n);
  void reserve(size_t n);  // room for n Gaussians in every array; sizes unchanged
  void clear() { resize(0); }
  void append(const GaussianParams& o, size_t i);  // copies Gaussian i of o to the end
  void append_range(const GaussianParams& o, size_t first, size_t n);  // Gaussians [first, first + n) of o
  void swap_remove(size_t i);                      // moves the last Gaussian into i
};

struct GaussianBlock {
  int sh_degree = kMaxShDegree;
  GaussianParams params;
  GaussianParams adam_m, adam_v;                  // Adam first and second moments, same layout
  std::vector<uint32_t> adam_steps;               // Adam step count per Gaussian (sparse updates)
  std::vector<uint32_t> created_by_keyframe;      // id of the keyframe that created it
  std::vector<uint32_t> created_at_step;          // optimiser iteration at creation
  std::vector<float> lr_position_factor;          // per-visit decayed position learning-rate factor

  size_t size() const { return params.size(); }
  void resize(size_t n);
  // Room for n Gaussians in every array, sizes unchanged: a resize(n) after it cannot throw, so a
  // caller that must not be left with arrays of different lengths reserves first.
  void reserve(size_t n);
  void append(const GaussianBlock& o, size_t i);
  void append_range(const GaussianBlock& o, size_t first, size_t n);
  void swap_remove(size_t i);
  // Throws Error when the arrays disagree in size (corrupt input) or sh_degree is out of range.
  void validate(const char* what) const;
};

// Host bytes of one Gaussian in a GaussianBlock: parameters and both Adam moments as float32, the
// step count, creator ids and position learning-rate factor.
constexpr size_t kBlockBytesPerGaussian = 3 * kParamFloats * sizeof(float) + 3 * sizeof(uint32_t) + sizeof(float);

}  // namespace chungs
