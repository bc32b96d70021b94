#include "chungs/serve/map_snapshot.hpp"

#include <cstdlib>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/mapping/sky_file.hpp"
#include "chungs/store/chunk_levels.hpp"
#include "chungs/store/map_folder.hpp"

namespace chungs::serve {

namespace fs = std::filesystem;

namespace {

uint64_t checkpoint_tag(const std::map<std::string, std::string>& config) {
  const auto it = config.find("checkpoint");
  return it == config.end() ? 0 : std::strtoull(it->second.c_str(), nullptr, 10);
}

nlohmann::json pose_json(const SE3& pose) {
  const Eigen::Matrix4d m = pose.matrix();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

nlohmann::json camera_json(const Camera& c) {
  return {{"width", c.width}, {"height", c.height}, {"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy}};
}

}  // namespace

MapSnapshot::MapSnapshot(const fs::path& folder) : folder_(folder) {
  require_map_manifest(folder);
  // The keyframe list is the mapper's, committed with the manifest under a numbered name first and
  // renamed after the commit; a reader renames nothing. When the manifest moved on while the list
  // was read, the list may belong to the next checkpoint: read everything again.
  // A read of the keyframe list and sky must fit between two commits; on a loaded machine beside a
  // mapper that commits every few keyframes, a fair share of attempts do not (5 gave up in a test run).
  constexpr int kAttempts = 20;
  std::string sky_damage;  // the final sky.bin not read, in the last attempt
  for (int attempt = 1;; ++attempt) {
    sky_damage.clear();
    store_ = std::make_unique<ChunkStore>(folder, reader_config());
    checkpoint_ = checkpoint_tag(store_->manifest().config);
    keyframes_.clear();
    const fs::path pending = checkpoint_file(folder, checkpoint_, "keyframes.txt");
    bool read = false;
    if (checkpoint_ > 0 && fs::exists(pending)) try {
        keyframes_ = read_keyframe_records(pending);
        read = true;
      } catch (const Error&) {
        if (fs::exists(pending)) throw;  // damaged, not renamed away meanwhile
      }
    if (!read && fs::exists(folder / "keyframes.txt")) keyframes_ = read_keyframe_records(folder / "keyframes.txt");
    timeline_.clear();
    const fs::path state = committed_file(folder, checkpoint_, "run_state.json");
    if (fs::is_regular_file(state)) try {
        const nlohmann::json j = read_json_file(state);
        if (j.is_object() && j.contains("timeline")) timeline_ = timeline_from_json(j["timeline"]);
      } catch (const std::exception& e) {
        // Renamed away by the next checkpoint meanwhile (the check below reads again), or damaged:
        // the charts are left out, the map is still shown.
        log::debug("viewer: timeline left out: ", e.what());
      }
    sky_.reset();
    const fs::path sky_pending = checkpoint_file(folder, checkpoint_, "sky.bin");
    bool sky_read = false;
    if (checkpoint_ > 0 && fs::exists(sky_pending)) try {
        sky_ = read_sky_file(sky_pending);
        sky_read = true;
      } catch (const Error& e) {
        // Still there, so damaged rather than renamed away meanwhile: the map is shown without it
        // (the final name holds an older checkpoint's sky).
        if (fs::exists(sky_pending)) {
          log::warn("viewer: sky left out: ", e.what());
          sky_read = true;
        }
      }
    if (!sky_read && fs::exists(folder / "sky.bin")) try {
        sky_ = read_sky_file(folder / "sky.bin");
      } catch (const Error& e) {
        // Replaced by the next checkpoint's while read (the check below reads again), or damaged:
        // said once the read is known to be of one commit.
        sky_damage = e.what();
      }
    if (checkpoint_tag(Manifest::read(folder / "manifest.txt").config) == checkpoint_) {
      if (!sky_damage.empty()) log::warn("viewer: the map's sky is left out, as its file does not read back: ", sky_damage);
      break;
    }
    if (attempt == kAttempts) fail(folder.string(), ": the map changed faster than it could be read; try again");
    log::info(folder.string(), ": the map was committed again while it was read; reading the new commit");
  }
  // Written once at the end of a run, after its last checkpoint: shown when present and whole.
  if (fs::is_regular_file(folder / "trajectory.txt")) try {
      trajectory_ = read_trajectory(folder / "trajectory.txt");
    } catch (const Error& e) {
      log::warn("viewer: trajectory left out: ", e.what());
    }
  if (fs::is_regular_file(folder / "report.json")) try {
      nlohmann::json j = read_json_file(folder / "report.json");
      if (j.is_object()) report_ = std::move(j);
    } catch (const Error& e) {
      log::warn("viewer: run statistics left out: ", e.what());
    }
}

nlohmann::json MapSnapshot::timeline_json() const {
  nlohmann::json j = nlohmann::json::object();
  auto column = [&](const char* name, auto get) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& t : timeline_) a.push_back(get(t));
    j[name] = std::move(a);
  };
  using T = TimelineSample;
  column("seconds", [](const T& t) { return t.seconds; });
  column("frame", [](const T& t) { return t.frame; });
  column("keyframes", [](const T& t) { return t.keyframes; });
  column("iterations", [](const T& t) { return t.iterations; });
  column("resident", [](const T& t) { return t.resident; });
  column("total", [](const T& t) { return t.total; });
  column("on_disk", [](const T& t) { return t.total > t.resident ? t.total - t.resident : 0; });
  column("rss_mb", [](const T& t) { return t.rss_mb; });
  column("vram_mb", [](const T& t) { return t.vram_mb; });
  column("loads", [](const T& t) { return t.loads; });
  column("saves", [](const T& t) { return t.saves; });
  column("disk_mb", [](const T& t) { return t.disk_mb; });
  column("wait_ms", [](const T& t) { return t.wait_ms; });
  return j;
}

Eigen::Vector3d MapSnapshot::origin() const {
  if (!keyframes_.empty()) return keyframes_.front().pose.t;
  if (!trajectory_.empty()) return trajectory_.poses.front().t;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const auto ids = store_->ids();
  for (ChunkId id : ids) sum += chunk_centre(chunk_coord(id), store_->chunk_size());
  return ids.empty() ? sum : Eigen::Vector3d(sum / double(ids.size()));
}

nlohmann::json MapSnapshot::describe() const {
  const Manifest m = store_->manifest();
  const double s = m.chunk_size;
  nlohmann::json chunks = nlohmann::json::array();
  for (const auto& [id, e] : m.chunks) {
    const ChunkCoord c = chunk_coord(id);
    Eigen::Vector3d lo, hi;
    chunk_box(c, s, lo, hi);
    chunks.push_back({{"id", std::to_string(id)},  // as text: JavaScript numbers hold 53 bits
                      {"coord", {c.x, c.y, c.z}},
                      {"min", {lo.x(), lo.y(), lo.z()}},
                      {"max", {hi.x(), hi.y(), hi.z()}},
                      {"count", e.count},
                      {"generation", e.generation},
                      {"level", is_far_level(id) ? "far" : "near"}});
  }
  nlohmann::json kfs = nlohmann::json::array();
  for (const auto& k : keyframes_)
    kfs.push_back({{"id", k.id}, {"frame", k.frame}, {"stamp", k.stamp}, {"pose", pose_json(k.pose)}});
  nlohmann::json traj = nlohmann::json::array();
  for (const auto& p : trajectory_.poses) traj.push_back({p.t.x(), p.t.y(), p.t.z()});
  const Eigen::Vector3d o = origin();
  nlohmann::json j = {{"format", 1},
                      {"checkpoint", checkpoint_},
                      {"chunk_size", s},
                      {"far_level_distance", map_far_level_distance(*store_)},
                      {"sh_degree", m.sh_degree},
                      {"total_gaussians", m.total_gaussians()},
                      {"origin", {o.x(), o.y(), o.z()}},
                      {"chunks", chunks},
                      {"keyframes", kfs},
                      {"trajectory", traj},
                      {"sky", sky_ ? nlohmann::json{{"width", sky_->width}, {"height", sky_->height}}
                                   : nlohmann::json(nullptr)},
                      {"camera", keyframes_.empty() ? nlohmann::json(nullptr) : camera_json(keyframes_.front().camera)},
                      {"report", report_ ? *report_ : nlohmann::json(nullptr)}};
  return j;
}

}  // namespace chungs::serve
