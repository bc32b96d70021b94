// The factor by which a setting tuned on images of `reference_px` pixels is raised on smaller
// images: sqrt(reference / pixels), at most 4; 1 at or above the reference, or with reference 0
// (off). Shared by the Adam rates and the sampler's density (issue 20: defaults across sizes).
#pragma once

namespace chungs {

double small_image_factor(double reference_px, int width, int height);

}  // namespace chungs
