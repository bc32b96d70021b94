// Applies a frame feed's pose updates to the map: translates the source's keyframe ids into the
// mapper's, leaves out keyframes that moved less than the configured thresholds (bundle adjustment
// nudges poses on every keyframe; moving Gaussians for millimetres would cost chunk loads for
// nothing, and the change is measured against the map's pose, so small steps still add up), and
// after a loop closure refines the junction for the configured number of steps.
#pragma once
#include <nlohmann/json.hpp>
#include <unordered_map>
#include <vector>

#include "chungs/pipeline/frame_feed.hpp"
#include "chungs/mapping/mapper.hpp"

namespace chungs {

class PoseUpdateApplier {
 public:
  PoseUpdateApplier(Mapper& mapper, const MapperConfig& config) : mapper_(mapper), config_(config) {}
  // The source's keyframe `source_id` became the mapper's keyframe `mapper_id`.
  void added(long source_id, uint32_t mapper_id) { ids_[source_id] = mapper_id; }
  struct Applied {
    size_t keyframes_moved = 0;
    bool loop = false;  // a loop closure was applied (worth a checkpoint of its own)
  };
  Applied apply(const std::vector<PoseUpdate>& updates);  // in order
  nlohmann::json report() const;  // counts, times, and each loop closure's statistics

 private:
  Mapper& mapper_;
  MapperConfig config_;
  std::unordered_map<long, uint32_t> ids_;
  size_t ba_updates_ = 0, ba_keyframes_ = 0, loops_ = 0, skipped_small_ = 0;
  double ba_ms_ = 0, loop_apply_ms_ = 0, loop_refine_ms_ = 0;
  nlohmann::json loops_json_ = nlohmann::json::array();
};

}  // namespace chungs
