// Optional learned monocular depth (issue 25): a user-supplied ONNX model run through ONNX Runtime,
// which is loaded at run time (dlopen), so the project builds and runs without it; then the model's
// relative inverse depth aligned to the tracker's sparse depths by a robust median/MAD fit.
//
// The model contract (README.md, "Learned monocular depth"):
// - one input, float32, [1, 3, H, W] (RGB planes); H and W fixed (the image is resized to them,
//   bilinear) or dynamic (the image goes in at its own size);
// - each channel normalised as (value / 255 - mean) / std, ImageNet's mean (0.485, 0.456, 0.406) and
//   std (0.229, 0.224, 0.225) unless the model's metadata says otherwise: keys `chungs.mean` and
//   `chungs.std`, three numbers separated by commas;
// - one output, float32, [1, 1, H', W'] or [1, H', W']: relative inverse depth (larger is nearer, an
//   unknown scale and shift; Depth-Anything's output), or depth when the metadata key `chungs.output`
//   is `depth` (then inverted); resized to the image's size (bilinear).
//
// The runtime is ONNX Runtime's shared library (libonnxruntime.so), found in this order: the file the
// environment variable CHUNGS_ONNXRUNTIME names, the copy the build installed from the npm package
// onnxruntime-node (cmake/onnxruntime.cmake), then the system's (libonnxruntime.so.1).
#pragma once
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "chungs/depth/prior_densify.hpp"  // DepthSample, DensePrior
#include "chungs/image/image.hpp"

namespace chungs {

class LearnedDepth {
 public:
  // Loads the model and checks it against the contract. Throws Error naming the file: missing, not an
  // ONNX model, inputs or outputs of the wrong count, type or shape, bad metadata, or the runtime not
  // installed (the message says what to install). threads: the runtime's threads per run (0: its
  // default, one per core).
  static std::unique_ptr<LearnedDepth> load(const std::filesystem::path& model, int threads = 0);
  ~LearnedDepth();
  LearnedDepth(const LearnedDepth&) = delete;
  LearnedDepth& operator=(const LearnedDepth&) = delete;

  // Relative inverse depth at the image's size (the contract's output, after resizing back). The
  // image is 8-bit RGB (gray is replicated). Safe to call from several threads at once.
  ImageF predict(const Image8& image) const;

  // One line: the file, the runtime's version, input and output shapes, the normalisation.
  std::string describe() const;

 private:
  struct Impl;
  explicit LearnedDepth(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The runtime's library as it would be loaded now, or the reason it cannot be (what to install).
struct DepthRuntimeProbe {
  bool available = false;
  std::string library;  // the file loaded
  std::string version;  // the runtime's own version string
  std::string reason;   // when not available
};
DepthRuntimeProbe probe_depth_runtime();

// A robust scale and shift in inverse depth: 1/depth = scale * prediction + shift.
struct InverseDepthFitOptions {
  size_t min_samples = 5;   // usable samples needed (the paper's 5 points in front of the camera)
  double outlier_mads = 5;  // samples whose residual is more than this many MADs from the median go
  double max_depth = 0;     // metres: deeper fitted pixels are invalid (0: no limit)
};

struct InverseDepthFit {
  bool ok = false;
  std::string refused;  // why, when !ok: too few usable samples, or no spread to fit a scale from
  double scale = 0, shift = 0;
  size_t samples = 0;   // usable: inside the image, finite prediction, positive finite depth
  size_t inliers = 0;   // kept by the final fit
  double median_rel_error = 0;  // over the inliers: median of |fitted depth - depth| / depth
};

// The fit on paired values (prediction, metric depth). Pairs with a non-finite prediction or a depth
// that is not positive and finite are not usable. First scale = MAD(1/depth) / MAD(prediction) and
// shift = median(1/depth) - scale * median(prediction); samples whose residual lies more than
// outlier_mads MADs of the residuals from their median are dropped (the MAD is at least 1e-9 of the
// median inverse depth: on exact data it is rounding), and the same fit runs once more on the rest
// (the paper's reference code refits once). A prediction that falls where inverse depth rises is
// refused: a depth model read as inverse depth.
InverseDepthFit fit_inverse_depth(const std::vector<double>& prediction, const std::vector<double>& depth,
                                  const InverseDepthFitOptions& options = {});

struct AlignedDepth {
  InverseDepthFit fit;
  DensePrior prior;  // inverse depth (1/m, 0 where the fit gives none) and confidence; empty when !fit.ok
  ImageF depth;      // metres, 0 where invalid; empty when !fit.ok
};

// prediction: LearnedDepth::predict's output; samples: metric depths at pixels (the tracker's map
// points projected into the keyframe), read from the prediction at the nearest pixel; those outside
// it are not usable. The confidence is exp(-|Sobel|^2 / 0.2) (3x3 Sobel, borders replicated) of the
// prediction normalised over the image as (p - median) / MAD, as the paper's reference code weighs its
// network depth: the plane sweep trusts the prior where it exceeds its min_prior_confidence.
// Never throws for too few or degenerate samples: fit.refused says why.
AlignedDepth align_inverse_depth(const ImageF& prediction, const std::vector<DepthSample>& samples,
                                 const InverseDepthFitOptions& options = {});

}  // namespace chungs
