// One committed checkpoint of a map folder, opened for the viewer's server: the chunk store as a
// reader (no lock; every chunk file of the manifest opened before any is read, manifest checksum
// checked), the keyframe list, run state (its timeline) and learned sky committed with it, and the
// run's trajectory and report when present.
// Nothing in the folder is created, repaired or changed. Chunk reads are safe from many threads.
#pragma once
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "chungs/geometry/trajectory.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/pipeline/timeline.hpp"
#include "chungs/render/sky.hpp"
#include "chungs/store/chunk_store.hpp"

namespace chungs::serve {

class MapSnapshot {
 public:
  // Throws Error naming the folder when it holds no map, or when a writer's commits outran five
  // attempts to read one checkpoint whole.
  explicit MapSnapshot(const std::filesystem::path& folder);

  const std::filesystem::path& folder() const { return folder_; }
  uint64_t checkpoint() const { return checkpoint_; }  // the manifest's checkpoint tag (0: none)
  const ChunkStore& store() const { return *store_; }
  const std::vector<KeyframeRecord>& keyframes() const { return keyframes_; }
  const Trajectory& trajectory() const { return trajectory_; }
  // report.json when the run wrote one that parses (its statistics are shown as they are).
  const std::optional<nlohmann::json>& report() const { return report_; }
  // The run's timeline as committed with this checkpoint (run_state.json; empty without one).
  const std::vector<TimelineSample>& timeline() const { return timeline_; }
  nlohmann::json timeline_json() const;  // /api/timeline: one array per quantity, sample by sample
  // The sky texture committed with this checkpoint (sky.bin; none for maps made without a sky, or
  // when the file is damaged: the map is shown without it).
  const std::optional<SkyTexture>& sky() const { return sky_; }
  // The point the page draws around: the first keyframe's position, else the chunks' mean centre.
  Eigen::Vector3d origin() const;

  // The description /api/map serves (see view_server.hpp).
  nlohmann::json describe() const;

 private:
  std::filesystem::path folder_;
  std::unique_ptr<ChunkStore> store_;
  uint64_t checkpoint_ = 0;
  std::vector<KeyframeRecord> keyframes_;
  Trajectory trajectory_;
  std::optional<nlohmann::json> report_;
  std::vector<TimelineSample> timeline_;
  std::optional<SkyTexture> sky_;
};

}  // namespace chungs::serve
