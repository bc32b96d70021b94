#include "chungs/synth/street_dataset.hpp"

#include "chungs/common/error.hpp"
#include "chungs/synth/sequence.hpp"

namespace chungs::synth {

struct StreetDataset::Renderer {
  Renderer(const StreetOptions& o, std::shared_ptr<StreetBlocks> blocks) : world(o, std::move(blocks)) {}
  StreetWorld world;
  Rasterizer rasterizer;
  RenderedFrame frame;
};

StreetDataset::StreetDataset(const StreetDatasetOptions& o) : options_(o) {
  if (!(o.street.length_m > 0))
    fail("synthetic street: length must be positive, got ", o.street.length_m, " m");
  if (o.width < 16 || o.height < 16 || o.width > kMaxImageSide || o.height > kMaxImageSide)
    fail("synthetic street: image size ", o.width, "x", o.height, " is out of range (16 to ", kMaxImageSide,
         " pixels a side)");
  trajectory_ = street_trajectory(o.street, o.max_frames);
  if (trajectory_.empty()) fail("synthetic street: the route of ", o.street.length_m, " m has no frames");
  info_.kind = "synth-street";
  info_.frames = trajectory_.size();
  info_.camera = kitti_camera(o.width, o.height);
  info_.baseline = kKittiBaseline;
  info_.has_right = true;
  info_.has_depth = o.depth;
  info_.has_gt = true;
  info_.color = true;
  info_.rate_hz = o.street.rate_hz;
  if (o.street.traffic > 0 || o.street.startup_cross) {
    auto full = o.max_frames ? street_trajectory(o.street) : trajectory_;
    traffic_ = std::make_shared<const StreetTraffic>(o.street, full);
  }
  blocks_ = std::make_shared<StreetBlocks>(o.street);
  idle_.push_back(std::make_unique<Renderer>(o.street, blocks_));  // fails early on bad street options
  idle_.back()->world.set_traffic(traffic_);
}

StreetDataset::~StreetDataset() = default;

void StreetDataset::check_index(size_t i) const {
  if (i >= info_.frames) fail("synthetic street: frame ", i, " is out of range (", info_.frames, " frames)");
}

std::unique_ptr<StreetDataset::Renderer> StreetDataset::take() const {
  {
    std::lock_guard lock(mutex_);
    if (!idle_.empty()) {
      auto r = std::move(idle_.back());
      idle_.pop_back();
      return r;
    }
  }
  auto r = std::make_unique<Renderer>(options_.street, blocks_);
  r->world.set_traffic(traffic_);
  return r;
}

void StreetDataset::give_back(std::unique_ptr<Renderer> r) const {
  std::lock_guard lock(mutex_);
  idle_.push_back(std::move(r));
}

Frame StreetDataset::frame(size_t i) const {
  check_index(i);
  std::unique_ptr<Renderer> r = take();
  RenderOptions ro;
  ro.far = options_.street.far;  // as `diskchungs synth street`
  r->world.set_time(trajectory_.stamps[i]);
  try {
    render_frame(r->rasterizer, r->world, info_.camera, trajectory_.poses[i], info_.baseline, ro, r->frame);
  } catch (const Error& e) {
    fail("synthetic street frame ", i, ": ", e.what());
  }
  Frame f;
  f.index = i;
  f.timestamp = trajectory_.stamps[i];
  f.left = std::move(r->frame.left);
  f.right = std::move(r->frame.right);
  if (options_.depth) f.depth = r->frame.depth;
  f.gt_pose = trajectory_.poses[i];
  f.camera = info_.camera;
  f.baseline = info_.baseline;
  f.source = "synthetic street frame " + std::to_string(i);
  give_back(std::move(r));
  return f;
}

double StreetDataset::timestamp(size_t i) const {
  check_index(i);
  return trajectory_.stamps[i];
}

std::optional<SE3> StreetDataset::gt_pose(size_t i) const {
  check_index(i);
  return trajectory_.poses[i];
}

}  // namespace chungs::synth
