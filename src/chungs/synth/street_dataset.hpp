// The synthetic street drive as a Dataset whose frames are rendered when asked for: a 10 km
// drive needs no 10 GB of image files. Frame i is bit-for-bit what `diskchungs synth street`
// writes for frame i with the same options (and the KITTI reader reads back): the same world,
// route, KITTI-like stereo camera and renderer.
//
// Thread-safe: frame() may be called from several threads at once (a prefetching mapper). Each
// concurrent call renders with its own world and rasterizer, taken from a pool that grows to the
// number of threads that call at the same time; their worlds share one cache of city blocks (at
// most StreetOptions::max_blocks, street_blocks.hpp), so a block is generated once for all.
#pragma once
#include <memory>
#include <mutex>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/synth/street.hpp"

namespace chungs::synth {

struct StreetDatasetOptions {
  StreetOptions street;  // seed, length_m, ... as `diskchungs synth street`
  int width = 1241, height = 376;
  size_t max_frames = 0;  // 0: the whole route
  bool depth = false;     // also hand out the rendered depth (the KITTI reader gives none)
  // Moving vehicles (street.traffic, startup_cross) are rendered at each frame's time, in both images and
  // the depth alike; such frames differ from `diskchungs synth street`'s, which has no traffic.
};

class StreetDataset : public Dataset {
 public:
  explicit StreetDataset(const StreetDatasetOptions& options);
  ~StreetDataset() override;
  const DatasetInfo& info() const override { return info_; }
  const StreetTraffic* traffic() const { return traffic_.get(); }
  Frame frame(size_t i) const override;  // throws Error naming the frame when out of range
  double timestamp(size_t i) const override;
  std::optional<SE3> gt_pose(size_t i) const override;

 private:
  struct Renderer;
  std::unique_ptr<Renderer> take() const;
  void give_back(std::unique_ptr<Renderer> r) const;
  void check_index(size_t i) const;

  StreetDatasetOptions options_;
  DatasetInfo info_;
  Trajectory trajectory_;
  std::shared_ptr<const StreetTraffic> traffic_;  // null without moving vehicles
  std::shared_ptr<StreetBlocks> blocks_;          // the city blocks, for every renderer
  mutable std::mutex mutex_;  // guards idle_
  mutable std::vector<std::unique_ptr<Renderer>> idle_;
};

}  // namespace chungs::synth
