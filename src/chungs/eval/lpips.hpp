// LPIPS v0.1 with AlexNet ('alex'), the learned perceptual distance 3DGS papers report beside PSNR
// and SSIM: 0 for identical images, larger for perceptually farther ones. Computed on the CPU in
// float32; it is only as meaningful as the weights, which the user supplies (LPIPS_WEIGHTS.md).
#pragma once
#include <array>
#include <filesystem>
#include <optional>
#include <string>

#include "chungs/eval/lpips_weights.hpp"
#include "chungs/image/image.hpp"

namespace chungs {

class Lpips {
 public:
  // Error when a tensor's size differs from kAlexConv's, or a head weight is negative.
  explicit Lpips(LpipsWeights weights, std::string source = "LPIPS weights");
  static Lpips load(const std::filesystem::path& file);

  // Both images in [0, 1], gray or RGB, the same shape and at least kLpipsMinSide on each side.
  double distance(const ImageF& a, const ImageF& b) const;
  // The five layers' terms, whose sum is distance().
  std::array<double, 5> layer_distances(const ImageF& a, const ImageF& b) const;
  const std::string& source() const { return source_; }

 private:
  LpipsWeights w_;
  std::string source_;
};

// LPIPS where weights were given, else the reason there is no number: reports print the reason,
// never a value made up in its place.
struct LpipsSetting {
  std::optional<Lpips> metric;
  std::string unavailable;  // empty when metric is set
};
// An empty path means "not given": the setting then says so, naming `flag`, as does an Error about the file.
LpipsSetting lpips_setting(const std::filesystem::path& weights, const std::string& flag);

}  // namespace chungs
