#ifdef CHUNGS_WITH_CUDA
#include "chungs/mapping/cuda/target_cache.hpp"

#include "chungs/common/error.hpp"

namespace chungs::cuda {

DeviceTargetCache::Entry& DeviceTargetCache::upload(const KeyframeImages& images, Entry& e) {
  const Image8& c = images.color;
  if (c.channels() < 1 || c.channels() > 4) fail("step targets: colour with ", c.channels(), " channels");
  if (!images.depth.empty() && (images.depth.width() != c.width() || images.depth.height() != c.height() ||
                                images.depth.channels() != 1))
    fail("step targets: depth ", images.depth.width(), "x", images.depth.height(), "x", images.depth.channels(),
         " does not match the ", c.width(), "x", c.height(), " image");
  e.color.upload(c.data(), c.size());
  if (images.depth.empty())
    e.depth.resize(0);
  else
    e.depth.upload(images.depth.data(), images.depth.size());
  e.width = c.width(), e.height = c.height(), e.channels = c.channels();
  e.bytes = c.size() + images.depth.size() * sizeof(float);
  ++uploads_;
  return e;
}

DeviceTargets DeviceTargetCache::expand(const StepTargets& targets, DeviceArray<float>& rgb,
                                        DeviceArray<float>& inv_depth, DeviceArray<uint8_t>& mask) {
  const Entry* e = nullptr;
  if (auto it = entries_.find(targets.key); targets.key != 0 && it != entries_.end()) {
    lru_.splice(lru_.begin(), lru_, it->second.lru);
    e = &it->second;
  } else {
    const auto images = targets.load();
    if (!images) fail("step targets: keyframe images missing");
    const size_t need = images->bytes();
    if (targets.key == 0 || need > capacity_ || max_entries_ == 0) {
      e = &upload(*images, scratch_);
    } else {
      while ((bytes_ + need > capacity_ || entries_.size() >= max_entries_) && !lru_.empty()) {
        auto victim = entries_.find(lru_.back());
        bytes_ -= victim->second.bytes;
        entries_.erase(victim);
        lru_.pop_back();
      }
      Entry fresh;
      upload(*images, fresh);  // may throw: nothing is recorded before it is on the device
      lru_.push_front(targets.key);
      fresh.lru = lru_.begin();
      bytes_ += fresh.bytes;
      e = &entries_.emplace(targets.key, std::move(fresh)).first->second;
    }
  }
  const size_t pixels = size_t(e->width) * size_t(e->height);
  const bool depth = targets.depth && !e->depth.empty();
  rgb.resize(pixels * 3);
  if (depth) {
    inv_depth.resize(pixels);
    mask.resize(pixels);
  }
  detail::launch_expand_targets(e->color.data(), e->channels, depth ? e->depth.data() : nullptr, pixels, rgb.data(),
                                depth ? inv_depth.data() : nullptr, depth ? mask.data() : nullptr);
  return {e->width, e->height, depth};
}

}  // namespace chungs::cuda
#endif
