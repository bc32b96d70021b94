// Loop closure: place recognition with a bag-of-words keyframe database, geometric verification (PnP-RANSAC
// against the candidate's points, then pose-only refinement), SE3 pose-graph optimisation over all keyframes
// (Sim(3) for a monocular map, whose scale drifts: the loop also measures the query side's scale against the
// candidate's), and the map correction (keyframes and points) reported as a LoopEvent for the mapper.
#pragma once
#include <filesystem>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "chungs/tracking/map.hpp"
#include "chungs/tracking/pose_graph.hpp"
#include "chungs/tracking/reprojection.hpp"
#include "chungs/tracking/tracker.hpp"
#include "chungs/tracking/vocabulary.hpp"

namespace chungs::tracking {

struct LoopOptions {
  std::filesystem::path vocabulary;  // trained vocabulary file; empty: train from the first keyframes
  int train_keyframes = 5;           // keyframes whose descriptors train the vocabulary when there is no file
  int branching = 10, levels = 3;
  int min_keyframe_gap = 20;         // a loop candidate is at least this many keyframes older
  int min_inliers = 40;              // verified matches needed to accept a loop
  int candidates = 3;                // recurring candidates verified per query, best score first
  int tracked_candidates = 10;       // best-scoring keyframes followed from query to query
  int consistency = 3;               // consecutive queries a candidate (or its neighbours) must recur in
  double max_drift_ratio = 0.2;      // reject loops moving the query more than this share of the path since
  double min_drift_gate = 0.5;       // the candidate, plus this many metres
  float scale_factor = 1.2f;
  bool similarity = false;           // monocular: Sim(3) loop correction (set by the tracker)
};

class LoopCloser {
 public:
  LoopCloser(LoopOptions opt, const Intrinsics& k, int width, int height);
  // Adds keyframe `kf` to the database and looks for a loop; on success corrects `map` in place and returns
  // the event (poses before and after for every keyframe that moved).
  std::optional<LoopEvent> process(Map& map, long kf);
  bool has_vocabulary() const { return vocab_.has_value(); }

 private:
  struct Verified {
    long candidate;
    SE3 T_wq;                                 // corrected pose of the query keyframe
    std::vector<std::pair<int, long>> pairs;  // query keypoint -> old point
    double scale = 1;                         // old map units per query-side map unit (similarity only)
  };
  std::optional<Verified> verify(Map& map, long query, long candidate) const;
  LoopEvent close(Map& map, long query, const Verified& v);
  void add_to_database(const Map& map, long kf);

  LoopOptions opt_;
  Intrinsics k_;
  int width_, height_;
  std::optional<Vocabulary> vocab_;
  std::vector<long> pending_;
  std::unordered_map<long, BowVector> bows_;
  std::unordered_map<int, std::vector<long>> inverted_;  // word -> keyframes containing it
  struct Group {
    std::unordered_set<long> members;  // a candidate and its covisible neighbours
    int count = 1;                     // consecutive queries that had it
  };
  std::vector<Group> groups_;          // the previous query's candidate groups
  std::vector<PoseGraphEdge> loop_edges_;
  long last_loop_kf_ = -1000000;
};

}  // namespace chungs::tracking
