#include "chungs/pipeline/frame_feed.hpp"

#include <cmath>

#include "chungs/pipeline/run_pipeline.hpp"

namespace chungs {

namespace {

class GivenPoseFeed : public FrameFeed {
 public:
  GivenPoseFeed(std::vector<std::optional<SE3>> poses, size_t start, size_t n, const MapperConfig& config,
                std::optional<SE3> last_keyframe)
      : poses_(std::move(poses)), next_(start), n_(n), config_(config), last_kf_(last_keyframe) {}

  std::optional<FeedItem> next() override {
    if (next_ >= n_) return std::nullopt;
    FeedItem item;
    item.frame = next_++;
    item.pose = item.frame < poses_.size() ? poses_[item.frame] : std::nullopt;
    item.keyframe_id = long(item.frame);
    if (!item.pose || is_held_out(item.frame, config_.holdout_every)) return item;
    const SE3& pose = *item.pose;
    ++since_keyframe_;
    bool key = !last_kf_;
    if (last_kf_) {
      const double moved = (pose.t - last_kf_->t).norm();
      const MapperConfig& c = config_;
      key = (c.keyframe_every > 0 && since_keyframe_ >= size_t(c.keyframe_every)) ||
            (c.keyframe_translation > 0 && moved >= c.keyframe_translation) ||
            // Until a keyframe's depth is known any motion counts: the view's scale is unknown.
            (c.keyframe_parallax > 0 && moved >= c.keyframe_parallax * scene_depth_ && moved > 0) ||
            (c.keyframe_rotation_deg > 0 &&
             (last_kf_->inverse() * pose).angle() * 180.0 / M_PI >= c.keyframe_rotation_deg);
    }
    if (key) {
      item.keyframe = true;
      since_keyframe_ = 0;
      last_kf_ = pose;
    }
    return item;
  }

  void set_scene_depth(double median_m) override {
    if (median_m > 0 && std::isfinite(median_m)) scene_depth_ = median_m;
  }
  std::vector<std::optional<SE3>> final_poses() override { return poses_; }
  nlohmann::json report() const override { return nlohmann::json::object(); }

 private:
  std::vector<std::optional<SE3>> poses_;
  size_t next_, n_;
  MapperConfig config_;
  std::optional<SE3> last_kf_;
  size_t since_keyframe_ = 0;
  double scene_depth_ = 0;  // median depth of the latest keyframe whose depth is known
};

}  // namespace

std::unique_ptr<FrameFeed> make_given_pose_feed(std::vector<std::optional<SE3>> poses, size_t start, size_t n,
                                                const MapperConfig& config, std::optional<SE3> last_keyframe) {
  return std::make_unique<GivenPoseFeed>(std::move(poses), start, n, config, last_keyframe);
}

}  // namespace chungs
