// A view rendered in passes, nearest first, when the Gaussians it sees do not fit in memory at once:
// each pass draws one group of chunks on its own, and the passes are composited front to back with
// the transmittance the nearer passes left. Chunks are cubes of the map's grid taken in order of
// their centres' distance, so along a ray a nearer pass's splats lie in front of a farther pass's
// except where splats overhang a chunk's faces; there the order of a few splats differs from one
// render of all of them. Before, the farthest chunks of such a view were left out of the render, and
// their pixels showed the sky.
#pragma once
#include <array>
#include <vector>

#include "chungs/render/render_output.hpp"

namespace chungs {

// Puts `back`, rendered over `background` alone, behind `front` (the passes so far, also over
// `background`): per pixel, with T = 1 - front.alpha the light the front lets through,
//   rgb += T (back.rgb - background)   (the background behind the front becomes the back pass)
//   depth += T back.depth, inv_depth += T back.inv_depth, alpha = 1 - T (1 - back.alpha);
// top_id stays the front's where it has one. Per-index arrays (visible, radius) are appended: the
// passes' index lists follow each other. Images must have the same size (throws Error otherwise).
void composite_behind(RenderOutput<float>& front, const RenderOutput<float>& back,
                      const std::array<double, 3>& background);

// Renders each group with render_group (over `background`, no sky) and composites them in order.
// Empty groups are skipped; with no group at all the result is empty (zero-sized images).
template <class Group, class RenderGroup>
RenderOutput<float> render_front_to_back(const std::vector<Group>& groups, RenderGroup&& render_group,
                                         const std::array<double, 3>& background) {
  RenderOutput<float> out;
  bool first = true;
  for (const Group& g : groups) {
    if (g.empty()) continue;
    if (first) {
      out = render_group(g);
      first = false;
    } else {
      composite_behind(out, render_group(g), background);
    }
  }
  return out;
}

}  // namespace chungs
