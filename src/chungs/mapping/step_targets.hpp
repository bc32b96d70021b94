// What one optimisation step is scored against, and its host form. A step names its keyframe's
// stored images by a key instead of handing over converted float images, so that a backend that
// keeps targets next to its computation (the CUDA backend keeps them in VRAM) converts and uploads
// each keyframe once rather than every step.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>

#include "chungs/image/image.hpp"
#include "chungs/store/keyframe_file.hpp"

namespace chungs {

struct StepTargets {
  uint64_t key = 0;    // the same key always names the same images; 0: not to be kept
  bool depth = false;  // score depth too, when the keyframe has a depth map
  // The keyframe's images (8-bit colour of 1-4 channels, metric depth); called only when the backend
  // holds no copy under `key`.
  std::function<std::shared_ptr<const KeyframeImages>()> load;
  // Pixels the step may learn from (1 channel, image size; non-zero: yes); null: all. A keyframe
  // trained on only the resident part of its view is scored where that part explains the image.
  const Image8* pixel_mask = nullptr;
};

// Float RGB target of an 8-bit image (gray replicated).
ImageF to_rgb_float(const Image8& img);
// Inverse depth (1/m, 0 invalid) and its validity mask.
void inverse_depth_of(const ImageF& depth, ImageF& inv, Image8& mask);

// The float targets the loss reads, computed on the host.
struct HostTargets {
  ImageF rgb, inv_depth;
  Image8 mask;
  bool depth = false;  // inv_depth and mask are set
};
HostTargets host_targets(const KeyframeImages& images, bool depth);

}  // namespace chungs
