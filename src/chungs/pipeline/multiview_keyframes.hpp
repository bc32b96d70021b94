// The multiview depth of a run from one camera (issue 25): the recent keyframes (frame, pose, the
// tracker's map points) the plane sweep of a new keyframe chooses its neighbours from, with their
// images at the mapping resolution.
//
// Where it runs: in the keyframe's load on the frame lookahead's worker threads, beside the decoding,
// so it overlaps the optimiser like stereo matching does. Keyframes are registered in feed order on the
// run's thread before their loads are queued (FrameLookahead::Seen); a load publishes its image first
// thing, and sweeps only against keyframes registered before it, whose loads the lookahead's FIFO
// started earlier, so a load waits only for loads already running, never for one queued behind it.
//
// The first keyframe has no earlier one: its sampling is deferred. At registration, a keyframe without
// a usable neighbour among the earlier ones is pending; the first later keyframe with which it has one
// computes its depth too (after its own), and the run samples it then (Mapper::add_late_depth).
//
// The guesses (the fill) of a keyframe are swept again in the load of the keyframe
// config.refresh_after mapped keyframes later, against the candidates that one's registration knew
// (itself and the keyframes between included): the load waits for the earlier keyframe's depth,
// whose load started first. Which keyframe a load refreshes is fixed at its registration.
//
// What a keyframe's sweeps choose from is fixed when it is registered: the keyframes before it and the
// scene depth known then. A load runs whenever a worker takes it, by which time the run may have
// registered later keyframes (pushing the oldest out of the window) and learnt a newer scene depth;
// read then, they made fixed pacing's maps differ from run to run.
#pragma once
#include <deque>
#include <future>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "chungs/datasets/dataset.hpp"
#include "chungs/depth/multiview_depth.hpp"
#include "chungs/pipeline/frame_feed.hpp"

namespace chungs {

class MultiviewKeyframes {
 public:
  // metric: the poses are in metres (given poses, or a tracker with depth); else the unit is the
  // monocular tracker's and the sweep's metre ranges follow the map points' depths. prior: null for no
  // prior (the wide sweep everywhere). Throws Error when the dataset's camera is distorted.
  MultiviewKeyframes(const Dataset& dataset, double resolution, const MultiviewDepthConfig& config, bool cuda,
                     bool metric, std::shared_ptr<const DepthPriorSource> prior);
  MultiviewKeyframes(const MultiviewKeyframes&) = delete;
  MultiviewKeyframes& operator=(const MultiviewKeyframes&) = delete;

  // The run's thread, in feed order, before the item's load is queued: a mapped keyframe with a pose,
  // the tracker's extra views, pose corrections.
  void seen(const FeedItem& item);
  // The run's thread: the median depth of a keyframe just loaded (the neighbour choice's scene depth).
  void set_scene_depth(double median);

  struct Result {
    std::optional<ImageF> depth;                       // none: no neighbour yet (deferred or none at all)
    std::vector<std::pair<size_t, ImageF>> late;       // earlier keyframes' deferred depth (frame, depth)
    // An earlier keyframe's guesses made again (config.refresh_after): depth at the guessed pixels the
    // sweep now gives depth, 0 elsewhere (frame, depth; Mapper::redepth).
    std::vector<std::pair<size_t, ImageF>> refresh;
  };
  // A loader thread: frame's image (the mapping resolution) is published for later sweeps, then its
  // depth computed. Call exactly once per registered keyframe, or failed() when its load failed.
  Result depth(size_t frame, const Image8& image);
  void failed(size_t frame, std::exception_ptr error);

  nlohmann::json report() const;

 private:
  struct Entry;
  std::shared_ptr<Entry> find(size_t frame) const;  // under mutex_
  std::shared_ptr<const Image8> image_of(Entry& e);
  // again: the reference's earlier depth, whose guesses alone are swept (MultiviewDepthInput::again);
  // none comes back when no guess got depth.
  std::optional<ImageF> sweep(const Entry& ref, const std::vector<std::shared_ptr<Entry>>& candidates,
                              const Image8& image, double scene_depth, const ImageF* again = nullptr);
  void publish_depth(Entry& e, std::shared_ptr<const ImageF> depth);  // once per entry, later calls ignored
  // scene_depth: the median depth the choice's triangulation angle refers to (0: unknown yet).
  std::vector<size_t> choose(const SE3& ref, const std::vector<SE3>& others, double scene_depth) const;

  const Dataset& dataset_;
  double resolution_;
  Camera camera_;  // at the mapping resolution
  MultiviewDepthConfig config_;
  bool metric_;
  std::shared_ptr<const DepthPriorSource> prior_;
  mutable std::mutex mutex_;
  std::deque<std::shared_ptr<Entry>> entries_;  // in feed order, the last config_.keep_keyframes
  std::vector<size_t> pending_;                 // frames whose depth waits for a neighbour
  double scene_depth_ = 0;                      // 0: unknown yet
  double units_per_metre_ = 1;                  // the latest estimate (monocular tracking)
  // Totals for the report.
  size_t keyframes_ = 0, deferred_ = 0, late_ = 0, without_ = 0, with_prior_ = 0, sweeps_ = 0;
  double ms_ = 0, valid_share_ = 0, filled_share_ = 0;
  uint64_t swept_ = 0, reswept_ = 0;
  uint64_t refreshed_ = 0;  // sweeps of earlier keyframes' guesses
  double refreshed_share_ = 0, refresh_ms_ = 0;
};

}  // namespace chungs
