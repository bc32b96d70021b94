// Following a map folder that a run is still writing: the manifest is looked at every interval, and
// when its checkpoint moved on, the folder is opened again as a reader (MapSnapshot) and becomes the
// current snapshot; requests in flight keep the one they started with. Each new checkpoint yields an
// event for the page (GET /api/events, server-sent events): the chunks added, changed (a new file
// generation) and removed, the newest keyframe's pose and the Gaussian total. The mapper is never
// waited on or locked: a checkpoint that cannot be read whole yet is tried again at the next look.
#pragma once
#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "chungs/serve/map_snapshot.hpp"

namespace chungs::serve {

class MapFollower {
 public:
  explicit MapFollower(std::shared_ptr<const MapSnapshot> first);
  // A folder a run has not committed to yet: current() is null until its first checkpoint, which
  // then comes as an event {"reload": true}.
  explicit MapFollower(std::filesystem::path folder);
  ~MapFollower();  // stops the thread
  MapFollower(const MapFollower&) = delete;
  MapFollower& operator=(const MapFollower&) = delete;

  std::shared_ptr<const MapSnapshot> current() const;  // null before a run's first checkpoint
  // The current snapshot and its version, taken together.
  std::shared_ptr<const MapSnapshot> current(uint64_t& version) const;
  uint64_t version() const;  // 0 for the first snapshot, +1 per checkpoint taken since

  // One look: reopens the folder when the manifest names another checkpoint. True when it took one.
  bool poll();
  // Looks every `interval` on a thread of its own until stop() or destruction.
  void start(std::chrono::milliseconds interval);
  void stop();
  bool stopped() const;

  // The events after `version` (each {"version", "checkpoint", "added", "changed", "removed",
  // "total_gaussians", "pose"}), waiting up to `timeout` for one when there is none. Events older than
  // the last 256 are gone: a client that far behind gets {"reload": true} and reads /api/map again.
  std::vector<nlohmann::json> events_after(uint64_t version, std::chrono::milliseconds timeout) const;

  // What changed between two snapshots, as an event without its version.
  static nlohmann::json difference(const MapSnapshot& before, const MapSnapshot& after);

 private:
  std::filesystem::path folder_;
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::shared_ptr<const MapSnapshot> current_;
  uint64_t version_ = 0;
  std::deque<nlohmann::json> events_;
  bool stop_ = false;
  std::thread thread_;
  std::string last_error_;  // logged once per distinct message
  std::filesystem::file_time_type seen_time_{};  // the manifest last read (poll's thread only)
  uintmax_t seen_size_ = 0;
  int unread_looks_ = 0;
};

}  // namespace chungs::serve
