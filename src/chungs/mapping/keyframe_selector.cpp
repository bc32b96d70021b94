#include "chungs/mapping/keyframe_selector.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs {

void KeyframeSelectorConfig::validate() const {
  if (!(revisit_share >= 0 && revisit_share < 1))
    fail("keyframe selector: revisit_share must be in [0, 1), got ", revisit_share);
  if (revisit_burst < 1 || revisit_burst > 100000)
    fail("keyframe selector: revisit_burst must be 1..100000 steps, got ", revisit_burst);
  if (!(revisit_min_distance >= 0 && std::isfinite(revisit_min_distance)))
    fail("keyframe selector: revisit_min_distance must be >= 0 metres, got ", revisit_min_distance);
  if (!(revisit_group_m >= 0 && std::isfinite(revisit_group_m)))
    fail("keyframe selector: revisit_group_m must be >= 0 metres, got ", revisit_group_m);
  if (!(cell_size > 0 && std::isfinite(cell_size)))
    fail("keyframe selector: cell_size must be a finite number of metres > 0, got ", cell_size);
  if (!(budget_cell_size > 0 && std::isfinite(budget_cell_size)))
    fail("keyframe selector: budget_cell_size must be a finite number of metres > 0, got ", budget_cell_size);
  if (new_uses < 1) fail("keyframe selector: new_uses must be >= 1, got ", new_uses);
  if (!(top_loss_fraction >= 0 && top_loss_fraction <= 1))
    fail("keyframe selector: top_loss_fraction must be in [0, 1], got ", top_loss_fraction);
  if (!(budget_share > 0 && budget_share <= 1))
    fail("keyframe selector: budget_share must be in (0, 1], got ", budget_share);
  if (!(min_partial_coverage >= 0 && min_partial_coverage <= 1))
    fail("keyframe selector: min_partial_coverage must be in [0, 1], got ", min_partial_coverage);
  if (!(best_view_share >= 0 && best_view_share <= 1))
    fail("keyframe selector: best_view_share must be in [0, 1], got ", best_view_share);
  if (!(core_share > 0 && core_share <= 1))
    fail("keyframe selector: core_share must be in (0, 1], got ", core_share);
}

KeyframeSelector::KeyframeSelector(const KeyframeSelectorConfig& config) : config_(config) { config_.validate(); }

KeyframeSelector::Cell KeyframeSelector::cell_of(const Eigen::Vector3d& p, double size) const {
  return {int64_t(std::floor(p.x() / size)), int64_t(std::floor(p.y() / size)), int64_t(std::floor(p.z() / size))};
}

void KeyframeSelector::add(uint32_t id, const Eigen::Vector3d& position, int uses, double last_loss) {
  if (!position.allFinite()) fail("keyframe selector: keyframe ", id, " has a non-finite position");
  if (!keyframes_.count(id)) order_.push_back(id);
  keyframes_[id] = {id, position, uses < 0 ? config_.new_uses : uses, last_loss};
  latest_ = id;
  window_.clear();
  cache_valid_[0] = cache_valid_[1] = false;
}

void KeyframeSelector::restrict_to(std::vector<uint32_t> ids) {
  std::sort(ids.begin(), ids.end());
  window_ = std::move(ids);
  cache_valid_[0] = cache_valid_[1] = false;
}

bool KeyframeSelector::in_window(uint32_t id) const {
  return window_.empty() || id == latest_ || std::binary_search(window_.begin(), window_.end(), id);
}

const std::vector<uint32_t>& KeyframeSelector::in_cell(PickScope scope) const {
  const int k = scope == PickScope::window ? 0 : 1;
  if (!cache_valid_[k]) {
    cached_[k] = find_in_cell(scope);
    cache_valid_[k] = true;
  }
  return cached_[k];
}

std::vector<uint32_t> KeyframeSelector::find_in_cell(PickScope scope) const {
  std::vector<uint32_t> out;
  if (keyframes_.empty()) return out;
  const Eigen::Vector3d& here = keyframes_.at(latest_).position;
  const double size = current_cell_size();
  const Cell c = cell_of(here, size);
  const double r2 = 0.25 * size * size;
  for (const auto& [id, k] : keyframes_) {
    const bool near =
        config_.around_latest ? (k.position - here).squaredNorm() <= r2 : cell_of(k.position, size) == c;
    if (window_.empty() ? near : (in_window(id) || (near && scope == PickScope::cell))) out.push_back(id);
  }
  if (config_.max_candidates > 0 && out.size() > config_.max_candidates) {
    // The nearest (ties: lower id), the latest first of all.
    const auto d2 = [&](uint32_t id) {
      return id == latest_ ? -1.0 : (keyframes_.at(id).position - here).squaredNorm();
    };
    std::nth_element(out.begin(), out.begin() + std::ptrdiff_t(config_.max_candidates - 1), out.end(),
                     [&](uint32_t a, uint32_t b) { return d2(a) != d2(b) ? d2(a) < d2(b) : a < b; });
    out.resize(config_.max_candidates);
  }
  std::sort(out.begin(), out.end());
  return out;
}

uint32_t KeyframeSelector::pick(std::mt19937_64& rng, PickScope scope) {
  const std::vector<uint32_t>& cand = in_cell(scope);
  if (cand.empty()) fail("keyframe selector: no keyframe to pick from");
  long long total = 0;
  for (uint32_t id : cand) total += keyframes_[id].uses;
  if (total == 0) {
    for (uint32_t id : cand) keyframes_[id].uses += 1;
    std::vector<uint32_t> by_loss = cand;
    std::stable_sort(by_loss.begin(), by_loss.end(),
                     [&](uint32_t a, uint32_t b) { return keyframes_[a].last_loss > keyframes_[b].last_loss; });
    const size_t top = size_t(std::ceil(config_.top_loss_fraction * double(by_loss.size())));
    for (size_t i = 0; i < top; ++i) keyframes_[by_loss[i]].uses += 1;
    total = 0;
    for (uint32_t id : cand) total += keyframes_[id].uses;
  }
  long long r = std::uniform_int_distribution<long long>(0, total - 1)(rng);
  for (uint32_t id : cand) {
    r -= keyframes_[id].uses;
    if (r < 0) {
      keyframes_[id].uses -= 1;
      return id;
    }
  }
  fail("keyframe selector: internal error in the weighted pick");
}

void KeyframeSelector::give_back(uint32_t id) {
  auto it = keyframes_.find(id);
  if (it == keyframes_.end()) fail("keyframe selector: no keyframe ", id);
  it->second.uses += 1;
}

void KeyframeSelector::report_loss(uint32_t id, double loss) {
  auto it = keyframes_.find(id);
  if (it == keyframes_.end()) fail("keyframe selector: loss for unknown keyframe ", id);
  it->second.last_loss = loss;
}

const KeyframeUsage& KeyframeSelector::usage(uint32_t id) const {
  auto it = keyframes_.find(id);
  if (it == keyframes_.end()) fail("keyframe selector: unknown keyframe ", id);
  return it->second;
}

std::vector<KeyframeUsage> KeyframeSelector::all() const {
  std::vector<KeyframeUsage> out;
  for (uint32_t id : order_) out.push_back(keyframes_.at(id));
  return out;
}

}  // namespace chungs
