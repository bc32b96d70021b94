#include "chungs/render/raster_config.hpp"

#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/image/small_image.hpp"

namespace chungs {

void RasterConfig::validate() const {
  if (!(near_plane > 0) || !std::isfinite(near_plane))
    fail("raster config: near_plane must be > 0, got ", near_plane);
  if (!(low_pass >= 0) || !std::isfinite(low_pass))
    fail("raster config: low_pass must be >= 0, got ", low_pass);
  if (!(alpha_max > 0 && alpha_max < 1)) fail("raster config: alpha_max must be in (0, 1), got ", alpha_max);
  if (!(min_alpha >= 0 && min_alpha < alpha_max))
    fail("raster config: min_alpha must be in [0, alpha_max), got ", min_alpha);
  if (!(min_transmittance >= 0 && min_transmittance < 1))
    fail("raster config: min_transmittance must be in [0, 1), got ", min_transmittance);
  if (!(extent_sigma > 0) || !std::isfinite(extent_sigma))
    fail("raster config: extent_sigma must be > 0, got ", extent_sigma);
  if (!(guard_band >= 1) || !std::isfinite(guard_band))
    fail("raster config: guard_band must be >= 1, got ", guard_band);
  if (segment_entries != 0 && (segment_entries < 32 || segment_entries > (1 << 24)))
    fail("raster config: segment_entries must be 0 (off) or in [32, 16777216], got ", segment_entries);
  if (sh_degree < 0 || sh_degree > 3) fail("raster config: sh_degree must be 0..3, got ", sh_degree);
  for (double b : background)
    if (!std::isfinite(b)) fail("raster config: background colour must be finite");
  if (!(small_image_reference_px >= 0) || !std::isfinite(small_image_reference_px))
    fail("raster config: small_image_reference_px must be >= 0 (0: off), got ", small_image_reference_px);
}

double RasterConfig::low_pass_for(int width, int height) const {
  const double f = small_image_factor(small_image_reference_px, width, height);
  return low_pass / (f * f);
}

}  // namespace chungs
