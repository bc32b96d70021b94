// The factor by which a setting tuned on images of `reference_px` pixels is raised on smaller
// images: sqrt(reference / pixels), at most 4; 1 at or above the reference, or with reference 0
// (off). Shared by the Adam rates (raised by it) and the rasterizer's low-pass (divided by its square).
#pragma once

namespace chungs {

double small_image_factor(double reference_px, int width, int height);

}  // namespace chungs
