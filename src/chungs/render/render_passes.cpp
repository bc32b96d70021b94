#include "chungs/render/render_passes.hpp"

#include "chungs/common/error.hpp"

namespace chungs {

void composite_behind(RenderOutput<float>& front, const RenderOutput<float>& back,
                      const std::array<double, 3>& background) {
  const int w = front.alpha.width(), h = front.alpha.height();
  if (!back.alpha.same_size(front.alpha) || !back.rgb.same_size(front.rgb) ||
      !front.rgb.same_size(front.alpha) || !back.depth.same_size(front.alpha) ||
      !back.inv_depth.same_size(front.alpha) || !front.depth.same_size(front.alpha) ||
      !front.inv_depth.same_size(front.alpha))
    fail("render passes: a pass rendered ", back.alpha.width(), "x", back.alpha.height(), ", the first ", w,
         "x", h);
  const bool tops = back.top_id.same_size(front.alpha) && front.top_id.same_size(front.alpha);
  const float b[3] = {float(background[0]), float(background[1]), float(background[2])};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float t = 1.f - front.alpha(x, y), t_back = 1.f - back.alpha(x, y);
      // front.rgb holds t * background where the back pass's splats now are.
      for (int c = 0; c < 3; ++c) front.rgb(x, y, c) += t * (back.rgb(x, y, c) - b[c]);
      front.depth(x, y) += t * back.depth(x, y);
      front.inv_depth(x, y) += t * back.inv_depth(x, y);
      front.alpha(x, y) = 1.f - t * t_back;
      if (tops && front.top_id(x, y) == kNoGaussian) front.top_id(x, y) = back.top_id(x, y);
    }
  front.visible.insert(front.visible.end(), back.visible.begin(), back.visible.end());
  front.radius.insert(front.radius.end(), back.radius.begin(), back.radius.end());
}

}  // namespace chungs
