// Weights of the mapping loss  (1 - lambda_ssim) * L1 + lambda_ssim * (1 - SSIM) + lambda_depth * L1(inverse
// depth).
#pragma once

namespace chungs {

struct LossConfig {
  double lambda_ssim = 0.2;
  double lambda_depth = 0.1;  // 0.1 indoor (TUM, Replica), 1.0 KITTI; 0 switches the depth term off

  static LossConfig indoor() { return {}; }
  static LossConfig kitti() { return {0.2, 1.0}; }
  void validate() const;  // throws Error for weights outside [0, 1] (ssim) or negative (depth)
};

}  // namespace chungs
