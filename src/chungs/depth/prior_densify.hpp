// A dense inverse-depth prior from sparse depth samples (the tracker's map points projected into a
// keyframe): normalized convolution at a few scales fills every pixel that some sample reaches, then a
// joint bilateral filter guided by the image pulls each pixel towards the samples of its own surface,
// so a depth step along an image edge stays a step instead of a ramp. Inverse depth throughout: it
// is what the plane sweep searches in, and far samples do not dominate the averages.
//
// Confidence says how far to trust the prior: near samples on the same side of every image edge it
// approaches 1; where only a coarse scale reached, it stays low, and the plane sweep then sweeps wide.
#pragma once
#include <vector>

#include "chungs/image/image.hpp"

namespace chungs {

struct DepthSample {
  float x = 0, y = 0;  // pixel (centres at integers)
  float depth = 0;     // metres along the optical axis
  float weight = 1;    // e.g. the map point's observation count; must be positive
};

struct DensifyConfig {
  int scales = 5;             // normalized-convolution scales sigma, 2 sigma, 4 sigma, ...
  double sigma_px = 3.0;      // the finest scale's Gaussian
  double scale_support = 0.5; // sample weight under a scale's Gaussian at which that scale is trusted alone
  int radius = 6;             // joint bilateral window: (2 radius + 1)^2
  double sigma_space = 4.0;   // pixels
  double sigma_color = 10.0;  // gray levels: an edge stronger than a few of these separates surfaces
  int iterations = 3;         // each carries the samples' values one window further along a surface
  double support = 0.5;       // colour-weighted sample weight at which the confidence is 1/2
  void validate() const;
};

struct DensePrior {
  ImageF inv_depth;   // 1/m, 0 where no sample reaches
  ImageF confidence;  // [0, 1], 0 where inv_depth is 0
};

// image: the keyframe (gray or RGB) that guides the filter. Samples whose pixel rounds outside it are
// not seen (map points project off the image all the time); a depth or weight that is not positive
// and finite, or a non-finite pixel, is an Error naming the sample.
DensePrior densify_prior(const Image8& image, const std::vector<DepthSample>& samples, const DensifyConfig& config = {});

}  // namespace chungs
