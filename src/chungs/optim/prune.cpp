#include "chungs/optim/prune.hpp"

#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

void PruneConfig::validate() const {
  if (!(min_opacity >= 0 && min_opacity < 1))
    fail("prune config: min_opacity must be in [0, 1), got ", min_opacity);
  if (!(max_radius_fraction >= 0) || !std::isfinite(max_radius_fraction))
    fail("prune config: max_radius_fraction must be >= 0 (0: no size test), got ", max_radius_fraction);
  if (every < 1) fail("prune config: every must be >= 1, got ", every);
  if (min_visits < 0) fail("prune config: min_visits must be >= 0, got ", min_visits);
}

std::vector<uint32_t> select_for_pruning(const PruneConfig& cfg, const GaussianArrays<float>& g,
                                         std::span<const uint32_t> ids, std::span<const float> radius,
                                         int image_width, std::span<const uint32_t> visits) {
  cfg.validate();
  if (!radius.empty() && radius.size() != ids.size())
    fail("pruning: ", ids.size(), " indices but ", radius.size(), " screen radii");
  if (!radius.empty() && image_width <= 0) fail("pruning: image width must be positive, got ", image_width);
  check_indices(g, ids.data(), ids.size(), "pruning");
  if (ids.size() > 0xFFFFFFFFu) fail("pruning: ", ids.size(), " indices do not fit 32-bit places");
  const bool aged = cfg.min_visits > 0;
  if (aged && visits.size() < g.capacity)
    fail("pruning: ", visits.size(), " visit counts for ", g.capacity, " Gaussians");
  // Compare logits instead of opacities: sigmoid is monotone, so this is the same test without exp.
  const float min_logit = cfg.min_opacity > 0 ? std::log(cfg.min_opacity / (1 - cfg.min_opacity)) : -INFINITY;
  const float max_radius = cfg.max_radius_fraction * float(image_width);
  const bool sized = cfg.max_radius_fraction > 0 && !radius.empty();
  std::vector<uint32_t> out;
  for (size_t j = 0; j < ids.size(); ++j) {
    // Written so that NaN (a diverged Gaussian) is pruned too.
    const float o = g.opacity[ids[j]];
    const bool young = aged && std::isfinite(o) && visits[ids[j]] < uint32_t(cfg.min_visits);
    const bool faint = !young && !(o >= min_logit);
    const bool huge = sized && !(radius[j] <= max_radius);
    if (faint || huge) out.push_back(uint32_t(j));
  }
  return out;
}

}  // namespace chungs
