#include "chungs/pipeline/multiview_keyframes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "chungs/common/error.hpp"
#include "chungs/pipeline/frame_source.hpp"

namespace chungs {

struct MultiviewKeyframes::Entry {
  uint64_t seq = 0;  // registration order
  size_t frame = 0;
  long id = -1;  // the feed's keyframe id (pose updates name it)
  SE3 pose;      // under mutex_
  std::vector<Eigen::Vector3d> points;
  bool mapped = false;  // a keyframe whose load publishes its image; else loaded here on first use
  std::promise<std::shared_ptr<const Image8>> promise;
  std::shared_future<std::shared_ptr<const Image8>> image;
  bool published = false;
  std::mutex lazy_mutex;
  std::shared_ptr<const Image8> lazy;
  std::vector<size_t> late;  // pending keyframes whose depth this one's load computes
  bool alone = false;        // no earlier neighbour at registration: pending
  // At registration (a mapped keyframe): the keyframes before it in the window and the scene depth;
  // released once its depth is computed.
  std::vector<std::shared_ptr<Entry>> earlier;
  double scene_depth = 0;
  // Its depth as computed, kept (under mutex_) until the keyframe that makes its guesses again takes
  // it; depth_known is ready once its load got that far (or failed) on every path.
  std::shared_ptr<const ImageF> depth;
  std::promise<void> depth_done;
  std::shared_future<void> depth_known = depth_done.get_future().share();
  bool depth_set = false;  // under mutex_
  std::shared_ptr<Entry> refresh;  // the earlier keyframe whose guesses this one's load sweeps again
};

namespace {

bool has_guesses(const ImageF& depth) {
  return std::any_of(depth.vec().begin(), depth.vec().end(), [](float z) { return z < 0; });
}

}  // namespace

void MultiviewKeyframes::publish_depth(Entry& e, std::shared_ptr<const ImageF> depth) {
  {
    std::lock_guard lock(mutex_);
    if (e.depth_set) return;
    e.depth_set = true;
    e.depth = std::move(depth);
  }
  e.depth_done.set_value();
}

MultiviewKeyframes::MultiviewKeyframes(const Dataset& dataset, double resolution, const MultiviewDepthConfig& config,
                                       bool cuda, bool metric, std::shared_ptr<const DepthPriorSource> prior)
    : dataset_(dataset), resolution_(resolution), config_(config), metric_(metric), prior_(std::move(prior)) {
  config_.validate();
  config_.sweep.cuda = cuda;
  camera_ = dataset.info().camera.scaled(resolution);
  if (camera_.distorted())
    fail("dataset ", dataset.info().path.string(), ": multiview depth needs undistorted images, its camera is ",
         camera_.describe());
}

std::shared_ptr<MultiviewKeyframes::Entry> MultiviewKeyframes::find(size_t frame) const {
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it)
    if ((*it)->frame == frame && (*it)->mapped) return *it;
  return nullptr;
}

std::vector<size_t> MultiviewKeyframes::choose(const SE3& ref, const std::vector<SE3>& others,
                                               double scene_depth) const {
  if (others.empty()) return {};
  NeighbourChoice c = config_.choice;
  c.count = config_.neighbours;
  c.scene_depth = scene_depth > 0 ? scene_depth : c.scene_depth * units_per_metre_;
  std::vector<SE3> poses{ref};
  poses.insert(poses.end(), others.begin(), others.end());
  std::vector<size_t> out = select_sweep_neighbours(camera_, poses, 0, c);
  for (size_t& k : out) --k;
  return out;
}

void MultiviewKeyframes::seen(const FeedItem& item) {
  std::lock_guard lock(mutex_);
  for (const PoseUpdate& u : item.updates)
    for (const auto& [id, pose] : u.poses)
      for (auto& e : entries_)
        if (e->id == id) e->pose = pose;
  auto add = [&](size_t frame, long id, const SE3& pose, bool mapped) {
    auto e = std::make_shared<Entry>();
    e->seq = entries_.empty() ? 0 : entries_.back()->seq + 1;
    e->frame = frame, e->id = id, e->pose = pose, e->mapped = mapped;
    e->image = e->promise.get_future().share();
    entries_.push_back(e);
    return e;
  };
  for (const FeedItem::View& v : item.sweep_views) add(v.frame, v.id, v.pose, false);
  if (!(item.keyframe && item.pose)) return;
  std::vector<std::shared_ptr<Entry>> before(entries_.begin(), entries_.end());
  std::vector<SE3> earlier;
  for (const auto& x : before) earlier.push_back(x->pose);
  const bool alone = choose(*item.pose, earlier, scene_depth_).empty();
  const auto e = add(item.frame, item.keyframe_id, *item.pose, true);
  e->points = item.map_points;
  if (config_.refresh_after > 0) {
    // The keyframe refresh_after mapped keyframes back, if its depth came from its own load.
    int back = config_.refresh_after;
    for (auto it = before.rbegin(); it != before.rend(); ++it)
      if ((*it)->mapped && --back == 0) {
        if (!(*it)->alone) e->refresh = *it;
        break;
      }
  }
  e->earlier = std::move(before);
  e->scene_depth = scene_depth_;
  ++keyframes_;
  // Pending keyframes this one gives a neighbour to: their depth is computed in its load.
  for (auto it = pending_.begin(); it != pending_.end();) {
    const auto p = find(*it);
    std::vector<SE3> others;
    for (const auto& x : entries_)
      if (x != p) others.push_back(x->pose);
    if (p && !choose(p->pose, others, scene_depth_).empty()) {
      e->late.push_back(*it);
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
  if (alone) {
    e->alone = true;
    pending_.push_back(item.frame);
    ++deferred_;
  }
  while (entries_.size() > size_t(config_.keep_keyframes)) {
    const size_t old = entries_.front()->frame;
    entries_.pop_front();
    if (auto it = std::find(pending_.begin(), pending_.end(), old); it != pending_.end() && !find(old)) {
      pending_.erase(it);
      ++without_;
    }
  }
}

void MultiviewKeyframes::set_scene_depth(double median) {
  if (!(median > 0 && std::isfinite(median))) return;
  std::lock_guard lock(mutex_);
  scene_depth_ = median;
}

std::shared_ptr<const Image8> MultiviewKeyframes::image_of(Entry& e) {
  if (e.mapped) {
    try {
      return e.image.get();
    } catch (...) {
      return nullptr;  // its load failed: the run reports that error itself
    }
  }
  std::lock_guard lock(e.lazy_mutex);
  if (!e.lazy) {
    Frame f = dataset_.frame(e.frame);
    e.lazy = std::make_shared<const Image8>(scale_image(f.left, resolution_));
  }
  return e.lazy;
}

void MultiviewKeyframes::failed(size_t frame, std::exception_ptr error) {
  std::shared_ptr<Entry> e;
  {
    std::lock_guard lock(mutex_);
    e = find(frame);
    if (!e || e->published) return;
    e->published = true;
    e->earlier.clear();
    e->refresh.reset();
  }
  e->promise.set_exception(error);
  publish_depth(*e, nullptr);
}

std::optional<ImageF> MultiviewKeyframes::sweep(const Entry& ref, const std::vector<std::shared_ptr<Entry>>& candidates,
                                                const Image8& image, double scene_depth, const ImageF* again) {
  const auto t0 = std::chrono::steady_clock::now();
  SE3 ref_pose;
  std::vector<SE3> poses;
  double upm;
  std::vector<size_t> chosen;
  {
    std::lock_guard lock(mutex_);
    ref_pose = ref.pose;
    for (const auto& c : candidates) poses.push_back(c->pose);
    upm = units_per_metre_;
  }
  MultiviewDepthInput in;
  in.camera = camera_;
  in.reference = {&image, ref_pose};
  in.points = project_points(ref.points, camera_, ref_pose);
  if (!metric_ && !in.points.empty()) {
    // One camera's unit: the sweep's ranges in metres follow the points' depths (the choice's scene
    // depth stands for a typical one).
    std::vector<float> z;
    for (const DepthSample& p : in.points) z.push_back(p.depth);
    std::nth_element(z.begin(), z.begin() + long(z.size() / 2), z.end());
    upm = double(z[z.size() / 2]) / config_.choice.scene_depth;
  }
  {
    std::lock_guard lock(mutex_);
    if (!again) units_per_metre_ = upm;
    chosen = choose(ref_pose, poses, scene_depth);
    if (chosen.empty() && !again) ++without_;
  }
  if (chosen.empty()) return std::nullopt;
  std::vector<std::shared_ptr<const Image8>> held;  // keeps the neighbours' images alive
  for (size_t k : chosen) {
    auto img = image_of(*candidates[k]);
    if (!img || img->width() != image.width() || img->height() != image.height()) continue;
    held.push_back(img);
    in.neighbours.push_back({img.get(), poses[k]});
  }
  if (in.neighbours.empty()) return std::nullopt;
  in.units_per_metre = upm;
  in.again = again;
  const MultiviewDepth d = multiview_depth(in, config_, prior_.get());
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (again) {
    std::lock_guard lock(mutex_);
    ++refreshed_;
    refreshed_share_ += double(d.valid) / double(std::max<size_t>(image.pixels(), 1));
    refresh_ms_ += ms;
    if (d.valid == 0) return std::nullopt;
    return d.depth;
  }
  {
    std::lock_guard lock(mutex_);
    ++sweeps_;
    with_prior_ += d.prior;
    swept_ += d.swept;
    reswept_ += d.reswept;
    valid_share_ += double(d.valid) / double(std::max<size_t>(image.pixels(), 1));
    filled_share_ += double(d.filled) / double(std::max<size_t>(image.pixels(), 1));
    ms_ += ms;
  }
  return d.depth;
}

MultiviewKeyframes::Result MultiviewKeyframes::depth(size_t frame, const Image8& image) {
  std::shared_ptr<Entry> e;
  std::vector<std::shared_ptr<Entry>> before;
  {
    std::lock_guard lock(mutex_);
    e = find(frame);
    if (!e) fail("multiview depth: frame ", frame, " was not registered as a keyframe");
    if (e->published) fail("multiview depth: frame ", frame, " was computed twice");
    e->published = true;
    before = std::move(e->earlier);
    e->earlier.clear();
  }
  e->promise.set_value(std::make_shared<const Image8>(image));
  Result r;
  try {
    if (!e->alone) r.depth = sweep(*e, before, image, e->scene_depth);
  } catch (...) {
    publish_depth(*e, nullptr);  // a later load waiting to make its guesses again goes on without
    throw;
  }
  publish_depth(*e, r.depth && config_.refresh_after > 0 && has_guesses(*r.depth)
                      ? std::make_shared<const ImageF>(*r.depth)
                      : nullptr);
  // An earlier keyframe against the ones this keyframe's registration knew, this one included.
  const auto others_than = [&](const std::shared_ptr<Entry>& earlier) {
    std::vector<std::shared_ptr<Entry>> others;
    for (const auto& x : before)
      if (x != earlier) others.push_back(x);
    others.push_back(e);
    return others;
  };
  for (size_t p : e->late) {
    std::shared_ptr<Entry> pe;
    for (const auto& x : before)
      if (x->frame == p && x->mapped) pe = x;
    if (!pe) continue;
    const auto img = image_of(*pe);
    if (!img) continue;
    if (auto d = sweep(*pe, others_than(pe), *img, e->scene_depth)) {
      r.late.emplace_back(p, std::move(*d));
      std::lock_guard lock(mutex_);
      ++late_;
    }
  }
  if (const std::shared_ptr<Entry> p = std::move(e->refresh)) {
    // Its loader started before this one's (registered earlier), so the wait ends.
    p->depth_known.wait();
    std::shared_ptr<const ImageF> earlier;
    {
      std::lock_guard lock(mutex_);
      earlier = std::move(p->depth);  // taken once: the image is freed after this sweep
    }
    const auto img = earlier ? image_of(*p) : nullptr;
    if (img)
      if (auto d = sweep(*p, others_than(p), *img, e->scene_depth, earlier.get()))
        r.refresh.emplace_back(p->frame, std::move(*d));
  }
  return r;
}

nlohmann::json MultiviewKeyframes::report() const {
  std::lock_guard lock(mutex_);
  const double n = double(std::max<size_t>(sweeps_, 1));
  return {{"keyframes", keyframes_},
          {"deferred", deferred_},
          {"deferred_then_sampled", late_},
          {"without_neighbour", without_},
          {"swept", sweeps_},
          {"with_prior", with_prior_},
          {"prior_source", prior_ ? prior_->name() : "none"},
          {"mean_ms", ms_ / n},
          {"swept_pixels_per_keyframe", double(swept_) / n},
          {"reswept_share", double(reswept_) / double(std::max<uint64_t>(swept_, 1))},
          {"valid_share", valid_share_ / n},
          {"filled_share", filled_share_ / n},
          {"refreshed", refreshed_},
          {"refreshed_share", refreshed_share_ / double(std::max<uint64_t>(refreshed_, 1))},
          {"refresh_mean_ms", refresh_ms_ / double(std::max<uint64_t>(refreshed_, 1))}};
}

}  // namespace chungs
