#include "chungs/mapping/frame_feed.hpp"

#include <cmath>

#include "chungs/mapping/run_pipeline.hpp"

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
    bool key = !last_kf_ || since_keyframe_ >= size_t(config_.keyframe_every);
    if (last_kf_ && config_.keyframe_translation > 0 && (pose.t - last_kf_->t).norm() >= config_.keyframe_translation)
      key = true;
    if (last_kf_ && config_.keyframe_rotation_deg > 0 &&
        (last_kf_->inverse() * pose).angle() * 180.0 / M_PI >= config_.keyframe_rotation_deg)
      key = true;
    if (key) {
      item.keyframe = true;
      since_keyframe_ = 0;
      last_kf_ = pose;
    }
    return item;
  }

  std::vector<std::optional<SE3>> final_poses() override { return poses_; }
  nlohmann::json report() const override { return nlohmann::json::object(); }

 private:
  std::vector<std::optional<SE3>> poses_;
  size_t next_, n_;
  MapperConfig config_;
  std::optional<SE3> last_kf_;
  size_t since_keyframe_ = 0;
};

}  // namespace

std::unique_ptr<FrameFeed> make_given_pose_feed(std::vector<std::optional<SE3>> poses, size_t start, size_t n,
                                                const MapperConfig& config, std::optional<SE3> last_keyframe) {
  return std::make_unique<GivenPoseFeed>(std::move(poses), start, n, config, last_keyframe);
}

}  // namespace chungs
