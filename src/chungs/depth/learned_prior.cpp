#include "chungs/depth/learned_prior.hpp"

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"

namespace chungs {

LearnedPrior::LearnedPrior(std::shared_ptr<const LearnedDepth> model, InverseDepthFitOptions fit,
                           std::shared_ptr<const DepthPriorSource> fallback)
    : model_(std::move(model)), fit_(fit), fallback_(std::move(fallback)) {
  if (!model_) fail("learned depth prior: no model");
}

std::optional<DensePrior> LearnedPrior::prior(const Image8& image, const std::vector<DepthSample>& points) const {
  // Too few points for any fit: the model's run, the costly part, is skipped.
  if (points.size() >= fit_.min_samples) {
    AlignedDepth a = align_inverse_depth(model_->predict(image), points, fit_);
    if (a.fit.ok) {
      ++aligned_;
      return std::move(a.prior);
    }
    log::debug("learned depth: no prior for a ", image.width(), "x", image.height(), " keyframe: ", a.fit.refused);
  }
  ++refused_;
  return fallback_ ? fallback_->prior(image, points) : std::nullopt;
}

}  // namespace chungs
