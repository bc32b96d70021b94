// The visual tracker as the mapper's frame feed (`diskchungs run --poses track`). The tracker runs on
// its own thread over every frame (held-out frames too: they are tracked, never trained on) and
// never waits for the mapper; each frame's result and the map operations it produced (keyframes,
// poses changed by bundle adjustment, loop closures) reach the mapper through a queue, in order.
#pragma once
#include <memory>
#include <nlohmann/json.hpp>

#include "chungs/datasets/dataset.hpp"
#include "chungs/pipeline/frame_feed.hpp"
#include "chungs/tracking/options.hpp"

namespace chungs::tracking {
struct TrackerTimings;
struct MapOperation;
}

namespace chungs {

// The tracker's time per frame, for `run`'s and `track`'s reports: tracking_ms_per_frame (the
// tracker thread's own work) and tracking_ms (features, those extracted ahead on the reader thread,
// pose, keyframes with their BA and loop parts).
nlohmann::json tracker_time_report(const tracking::TrackerTimings& t);
// A tracker's map operation (bundle adjustment or loop closure) as the pose update the mapper applies.
PoseUpdate pose_update_of(const tracking::MapOperation& op);

// Tracks frames [0, n) of the dataset, which must outlive the feed.
std::unique_ptr<FrameFeed> make_tracker_feed(const Dataset& dataset, size_t n, const MapperConfig& config,
                                             const tracking::TrackerOptions& options);

}  // namespace chungs
