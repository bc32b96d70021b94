#include "chungs/image/small_image.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

double small_image_factor(double reference_px, int width, int height) {
  if (width <= 0 || height <= 0) fail("image size must be positive, got ", width, "x", height);
  const double pixels = double(width) * double(height);
  if (reference_px <= 0 || pixels >= reference_px) return 1.0;
  return std::min(4.0, std::sqrt(reference_px / pixels));
}

}  // namespace chungs
