// Sparse Adam over the pool's Gaussians: each step updates only the Gaussians that were visible in
// the render, with a per-Gaussian step count for the bias correction (a Gaussian seen for the 3rd
// time gets the 3rd-step correction however many steps the map has taken), and a per-Gaussian
// position learning rate that decays with every visit down to a floor.
#pragma once
#include <cstdint>
#include <span>

#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/render/gaussian_view.hpp"

namespace chungs {

struct AdamConfig {
  // Learning rates per parameter kind (DiskChunGS defaults; the SH split follows 3D Gaussian
  // Splatting: the degree-0 "features" at 0.005, the higher bands 20x slower).
  // Metres. The paper's 1e-3 outdoors, here indoors too: its indoor 5e-5 left new Gaussians where their
  // depth put them, and 1e-3 scored +1.2 to +1.5 dB held-out on the synthetic room, Replica office0 (300x170
  // and 600x340, RGB-D) and the EuRoC excerpt, and +0.5 / +1.2 dB on the room and Replica from one camera
  // (bench/README.md, "One position learning rate").
  float lr_position = 1e-3f;
  // One camera: depth from the plane sweep is a guess (AbsRel 0.1-0.14), so its Gaussians need to move
  // further than measured depth's; run multiplies lr_position by this there. 3 scored +1.1 dB held-out on
  // Replica office0 from one camera, +0.3 on the room, +0.1 on KITTI's left camera; 6 then +0.6 on Replica
  // and +0.3 on KITTI on the GPU, the room unchanged (bench/README.md, "A second sweep").
  float multiview_position_factor = 6.0f;
  float position_decay = 0.998f;    // position lr factor *= decay on every visit
  float position_lr_floor = 0.01f;  // ... but never below this fraction of lr_position
  float lr_sh_dc = 0.005f;
  float lr_sh_rest = 0.005f / 20.0f;
  // On the logit. The paper's 0.1 moves a new Gaussian (opacity 0.07) below the pruning threshold
  // (0.05) in about four steps of one sign. 0.05 (3D Gaussian Splatting's) with prune.min_visits 50
  // keeps 1.6x the map and scores 0.1-0.5 dB more with the default budget, but loses 0.4-0.5 dB under
  // 300 k / 100 k budgets (bench/README, issue 20): not the default.
  float lr_opacity = 0.1f;
  float lr_scale = 0.01f;      // on the log scale
  float lr_rotation = 0.002f;  // on the raw quaternion
  float beta1 = 0.9f, beta2 = 0.999f;
  float eps = 1e-15f;  // as in 3D Gaussian Splatting
  // The rates above hold for images of at least this many pixels (620x188). On smaller images the
  // rates of opacity, colour (degree 0) and scale are multiplied by sqrt(reference / pixels), at most
  // 4x: a 310x94 map at 10 steps per keyframe scored 2.5 dB under 620x188 with the same keyframes and
  // steps, and twice these rates gave it +0.56..+0.7 dB on two streets, where at 620x188 they gave
  // nothing (bench/README.md, issue 20). 0: the rates as given at any size.
  double small_image_reference_px = 620.0 * 188.0;
  // The rates above are for keyframes trained this many steps each. Keyframes trained longer get the
  // rates of opacity, colour (degree 0) and scale x sqrt(reference / steps), as SGD's noise asks when
  // one view is fitted N times as often: on the 2 km street at 300 steps per keyframe the constant
  // rates scored 27.84 dB held-out, x0.5 28.28 and x0.316 28.44 (KITTI 24.33 / 24.31 / 24.41;
  // bench/README.md, issue 20). 0: the rates as given at any number of steps.
  double reference_steps = 30;

  void validate() const;  // throws Error naming the first field out of range
  // The factor on opacity, colour and scale rates for images of that size (1 at or above the reference).
  double small_image_factor(int width, int height) const;
  // This configuration with those rates scaled for images of that size.
  AdamConfig for_image(int width, int height) const;
  // The factor on opacity, colour and scale rates for keyframes that get this many steps each
  // (1 at or below reference_steps, or when steps is not a positive number).
  double steps_factor(double steps_per_keyframe) const;
  // This configuration with those rates scaled for that many steps per keyframe.
  AdamConfig for_steps(double steps_per_keyframe) const;
};

// The optimiser state arrays of the pool, per slot, in the GaussianBlock layout.
struct AdamState {
  GaussianArraysMut<float> m, v;
  uint32_t* steps = nullptr;
  float* lr_position_factor = nullptr;  // starts at 1 for a new Gaussian
  size_t capacity = 0;
};

AdamState adam_state_of(GaussianBlock& block);

// One step for the Gaussians ids[j] with visible[j] != 0, using grads entry j (the rasterizer's
// compact layout). ids must be distinct (each slot once). Per visible Gaussian: steps += 1; every
// parameter gets lr * m_hat / (sqrt(v_hat) + eps); the position uses lr_position times the slot's
// factor, and the factor is then multiplied by position_decay, not below position_lr_floor.
// Throws Error when sizes disagree or an index is out of range.
void sparse_adam_step(const AdamConfig& config, const GaussianArraysMut<float>& params,
                      const AdamState& state, std::span<const uint32_t> ids, std::span<const uint8_t> visible,
                      const GaussianGrads<float>& grads);

}  // namespace chungs
