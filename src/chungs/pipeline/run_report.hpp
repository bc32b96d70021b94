// The parts of `run`'s report.json that the mapper's own counters make: whether the optimiser kept
// up (pacing), where a step's time went, host and device memory, chunk and keyframe I/O.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "chungs/mapping/mapper.hpp"
#include "chungs/pipeline/timeline.hpp"

namespace chungs {

nlohmann::json pacing_report(const Mapper& mapper, const std::vector<TimelineSample>& timeline,
                             int min_steps_per_keyframe, uint64_t refinement_steps);
// The run summary's pacing line from a whole report (its "pacing", "settings" and "time"): steps per
// keyframe and what bounds them, drops, checkpoints, I/O wait, and Gaussians sampled and pruned (per
// 100 m when pacing_summary gave rates, else totals over the path). No newline.
std::string pacing_line(const nlohmann::json& report);
// One line for the run's summary when the budget narrowed training (pacing_report's "training_window",
// its narrowed_share above 0); empty otherwise.
std::string training_window_line(const nlohmann::json& pacing);
nlohmann::json step_report(const Mapper::StepTimes& t);  // per step, ms; t.steps > 0
nlohmann::json memory_report(const Mapper& mapper, const std::vector<TimelineSample>& timeline);
nlohmann::json chunk_io_report(const IoStats& io, double map_seconds);
// The refinement after the last frame: its steps and groups, its time, where its steps' time went
// (steps: the StepTimes of the refinement alone) and its chunk I/O (io: the counters' change over it,
// reported as chunk_io_report does with the refinement's seconds).
nlohmann::json refinement_report(const Mapper::RefineStats& r, double seconds, const Mapper::StepTimes& steps,
                                 const IoStats& io);
nlohmann::json keyframe_io_report(const IoStats& kio);

}  // namespace chungs
