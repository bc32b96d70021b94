#include "chungs/mapping/step_targets.hpp"

#include <cmath>

namespace chungs {

ImageF to_rgb_float(const Image8& img) { return to_rgb(to_float(img)); }

void inverse_depth_of(const ImageF& depth, ImageF& inv, Image8& mask) {
  inv = ImageF(depth.width(), depth.height(), 1, 0.f);
  mask = Image8(depth.width(), depth.height(), 1, 0);
  for (size_t i = 0; i < depth.pixels(); ++i) {
    const float d = depth.data()[i];
    if (d > 0 && std::isfinite(d)) {
      inv.data()[i] = 1.f / d;
      mask.data()[i] = 1;
    }
  }
}

HostTargets host_targets(const KeyframeImages& images, bool depth) {
  HostTargets t;
  t.rgb = to_rgb_float(images.color);
  t.depth = depth && !images.depth.empty();
  if (t.depth) inverse_depth_of(images.depth, t.inv_depth, t.mask);
  return t;
}

}  // namespace chungs
