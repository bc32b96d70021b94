#include "chungs/synth/street_blocks.hpp"

#include <algorithm>
#include <vector>

#include "chungs/synth/street.hpp"

namespace chungs::synth {

StreetBlocks::StreetBlocks(const StreetOptions& opt) : opt_(std::make_unique<const StreetOptions>(opt)) {}

StreetBlocks::~StreetBlocks() = default;

std::shared_ptr<const Mesh> StreetBlocks::get(int bx, int by) {
  const int64_t k = key(bx, by);
  {
    std::lock_guard lock(mutex_);
    if (auto it = cache_.find(k); it != cache_.end()) {
      it->second.last_used = ++clock_;
      return it->second.mesh;
    }
  }
  auto mesh = std::make_shared<const Mesh>(build_street_block(*opt_, bx, by));
  std::lock_guard lock(mutex_);
  auto [it, fresh] = cache_.try_emplace(k, Entry{mesh, 0});
  it->second.last_used = ++clock_;
  if (fresh) {
    ++generated_;
    distinct_[k] = mesh->triangles();
    evict_locked();
  }
  return it->second.mesh;
}

void StreetBlocks::evict_locked() {
  if (cache_.size() <= opt_->max_blocks) return;
  std::vector<std::pair<uint64_t, int64_t>> order;
  order.reserve(cache_.size());
  for (const auto& [k, e] : cache_) order.push_back({e.last_used, k});
  std::sort(order.begin(), order.end());
  // Drop to 90 % so that eviction does not run on every new block; the newest stays.
  const size_t target = opt_->max_blocks * 9 / 10;
  for (size_t i = 0; i + 1 < order.size() && cache_.size() > target; ++i) cache_.erase(order[i].second);
}

size_t StreetBlocks::in_memory() const {
  std::lock_guard lock(mutex_);
  return cache_.size();
}

size_t StreetBlocks::generated() const {
  std::lock_guard lock(mutex_);
  return generated_;
}

size_t StreetBlocks::distinct() const {
  std::lock_guard lock(mutex_);
  return distinct_.size();
}

size_t StreetBlocks::distinct_triangles() const {
  std::lock_guard lock(mutex_);
  size_t n = 0;
  for (const auto& [k, t] : distinct_) n += t;
  return n;
}

size_t StreetBlocks::triangles() const {
  std::lock_guard lock(mutex_);
  size_t n = 0;
  for (const auto& [k, e] : cache_) n += e.mesh->triangles();
  return n;
}

}  // namespace chungs::synth
