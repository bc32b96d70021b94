// A learned model as the plane sweep's prior source (issue 25): the model's relative inverse depth
// for the keyframe (learned_depth.hpp), aligned to the tracker's map points seen in it by the
// median/MAD fit, in the points' units. Where the fit is refused (too few points, no spread, a
// prediction that disagrees with them) the fallback source answers instead (the map points
// densified), and without one there is no prior: the sweep goes wide there.
#pragma once
#include <atomic>
#include <memory>

#include "chungs/depth/learned_depth.hpp"
#include "chungs/depth/multiview_depth.hpp"

namespace chungs {

class LearnedPrior : public DepthPriorSource {
 public:
  // Throws Error without a model.
  LearnedPrior(std::shared_ptr<const LearnedDepth> model, InverseDepthFitOptions fit = {},
               std::shared_ptr<const DepthPriorSource> fallback = nullptr);
  std::string name() const override { return "learned depth"; }
  std::optional<DensePrior> prior(const Image8& image, const std::vector<DepthSample>& points) const override;

  size_t aligned() const { return aligned_; }  // keyframes given the model's aligned prediction
  size_t refused() const { return refused_; }  // keyframes whose fit was refused (the fallback's turn)

 private:
  std::shared_ptr<const LearnedDepth> model_;
  InverseDepthFitOptions fit_;
  std::shared_ptr<const DepthPriorSource> fallback_;
  mutable std::atomic<size_t> aligned_{0}, refused_{0};
};

}  // namespace chungs
