// The sampler's edge probability: a Laplacian-of-Gaussian response of an image, normalised to a
// per-pixel probability in [0, 1] (DiskChunGS §Sampling).
#pragma once
#include "chungs/image/image.hpp"

namespace chungs {

// Steps: two 3x3 box blurs, the 3x3 Laplacian (4-neighbour) of each channel summed over channels,
// absolute value with a zero 1-pixel border, averaged over a disc of radius 3.5 px (the 37 pixels of
// a 7x7 window within the radius), clamped to [0, 1]. Input: float image with 1-4 channels.
ImageF log_probability(const ImageF& image);

}  // namespace chungs
