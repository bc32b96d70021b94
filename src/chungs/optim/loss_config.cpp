#include "chungs/optim/loss_config.hpp"

#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

void LossConfig::validate() const {
  if (!(lambda_ssim >= 0 && lambda_ssim <= 1))
    fail("loss config: lambda_ssim must be in [0, 1], got ", lambda_ssim);
  if (!(lambda_depth >= 0) || !std::isfinite(lambda_depth))
    fail("loss config: lambda_depth must be >= 0, got ", lambda_depth);
}

}  // namespace chungs
