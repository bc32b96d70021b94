#include "chungs/pipeline/resume_point.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <system_error>

#include "chungs/common/error.hpp"
#include "chungs/mapping/map_state.hpp"

namespace chungs {

ResumePoint resume_point(const RunOptions& o, const nlohmann::json& state, size_t frames, size_t mapped,
                         double resolution) {
  ResumePoint p;
  if (!o.resume || state.is_null()) return p;
  if (state.value("dataset", std::string()) != o.dataset)
    fail(o.out.string(), ": the map was made from ", state.value("dataset", std::string("?")), ", not ", o.dataset);
  // The rest of the map on other poses than its start would not line up with it.
  const std::string had = state.value("poses", std::string());
  std::error_code ec;
  const bool same_poses = had.empty() || had == o.poses ||
                          (had != "gt" && o.poses != "gt" && std::filesystem::equivalent(had, o.poses, ec));
  if (!same_poses)
    fail(o.out.string(), ": the map was made on --poses ", had, ", not ", o.poses,
         "; --resume goes on with the poses it was made on");
  // Keyframes at another size would train one map at two scales of detail, its sampler and learning
  // rates tuned to one; maps committed before the state named its resolution go on unchecked.
  if (const std::optional<double> had_resolution = other_resolution(state, resolution))
    fail("--resolution ", resolution, ": the map in ", o.out.string(), " was made at resolution ", *had_resolution,
         "; --resume goes on at the map's resolution (leave --resolution out or give ", *had_resolution, ")");
  // Frames held out by one rule and trained by the other would be scored as never seen: the held-out
  // figures of the resumed map would count frames it was trained on. Maps whose state predates the key
  // go on unchecked.
  if (state.is_object() && state.contains("holdout_every") && state["holdout_every"].is_number_unsigned() &&
      state["holdout_every"].get<uint64_t>() != uint64_t(std::max(o.config.mapper.holdout_every, 0)))
    fail("mapper.holdout_every ", o.config.mapper.holdout_every, ": the map in ", o.out.string(), " was made holding out ",
         state["holdout_every"].get<uint64_t>() == 0 ? std::string("no frame")
                                                     : cat("every ", state["holdout_every"].get<uint64_t>(), "th frame"),
         "; --resume goes on with the map's rule (give holdout_every ", state["holdout_every"].get<uint64_t>(), ")");
  p.start = resume_frame(state, o.out / "run_state.json", frames);
  // Fewer frames than the map covers would write that smaller count as where it stands: a later
  // --resume would then map the frames between again, on top of their Gaussians.
  if (p.start > mapped)
    fail("--max-frames ", o.max_frames, ": the map in ", o.out.string(), " already covers ", p.start,
         " frames; give at least ", p.start, " or leave it out");
  p.seconds = state.value("seconds", 0.0);
  try {
    if (state.contains("timeline")) p.timeline = timeline_from_json(state["timeline"]);
  } catch (const std::exception& e) {
    fail(o.out.string(), "/run_state.json: 'timeline' is damaged (", e.what(), ")");
  }
  return p;
}

std::optional<double> other_resolution(const nlohmann::json& state, double resolution) {
  if (!state.is_object()) return std::nullopt;
  const auto r = state.find("resolution");
  if (r == state.end() || !r->is_number() || std::abs(r->get<double>() - resolution) <= 1e-9) return std::nullopt;
  return r->get<double>();
}

}  // namespace chungs
