// The mapper's own part of a map folder, beside the chunk files and manifest: the keyframe list
// (id, frame, camera, pose, selector usage) and a JSON run state, both replaced crash-safely, so
// `--resume` continues from the last checkpoint.
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "chungs/common/text_pieces.hpp"
#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"

namespace chungs {

struct KeyframeRecord {
  uint32_t id = 0;
  uint64_t frame = 0;
  double stamp = 0;
  Camera camera;
  SE3 pose;  // camera-to-world
  int uses = 0;
  double last_loss = 0;
  uint32_t depth_version = 0;  // bumped when its stored depth changes (Mapper::redepth); not saved
};

void write_keyframe_records(const std::filesystem::path& file, const std::vector<KeyframeRecord>& records,
                            bool durable);
void append_keyframe_records_header(TextPieces& out);
void append_keyframe_record(TextPieces& out, const KeyframeRecord& r);
// What the file holds, for records in any container (a checkpoint's copy is a deque: no block as large as the
// list).
template <class Records>
TextPieces keyframe_records_text(const Records& records) {
  TextPieces out;
  append_keyframe_records_header(out);
  for (const KeyframeRecord& r : records) append_keyframe_record(out, r);
  return out;
}
// Throws Error "FILE:LINE: ..." on malformed lines.
std::vector<KeyframeRecord> read_keyframe_records(const std::filesystem::path& file);

// A checkpoint's keyframe list, run state or sky under the numbered name it is written with before
// the commit that names checkpoint `seq` (Mapper::checkpoint).
std::filesystem::path checkpoint_file(const std::filesystem::path& folder, uint64_t seq,
                                      const std::string& final_name);
// The file as checkpoint `seq` commits it, for readers: its numbered copy while that still waits for
// its final name (a run that failed between the commit and the renaming, which only a writer
// finishes), else the file under its final name.
std::filesystem::path committed_file(const std::filesystem::path& folder, uint64_t seq,
                                     const std::string& final_name);

// Whether the folder holds a map to resume: a keyframe list, or a manifest naming a checkpoint or a
// chunk. What a run left before its first checkpoint (an empty manifest) is no map: a new run starts
// there afresh, as the README says. A manifest that does not read back counts as a map (the store names it).
bool holds_a_map(const std::filesystem::path& folder);
// A new map goes into a new or empty folder, or one a run left before its first checkpoint (its
// chunks folder, and only files a run makes); any other folder is refused naming a few of its
// files, since the run would write its report, trajectory and plots over files of the same names.
void require_folder_for_new_map(const std::filesystem::path& folder);

void write_json_atomically(const std::filesystem::path& file, const nlohmann::json& j, bool durable);
void write_text_atomically(const std::filesystem::path& file, const std::string& text, bool durable);
void write_text_atomically(const std::filesystem::path& file, const TextPieces& text, bool durable);
nlohmann::json read_json_file(const std::filesystem::path& file);
// run_state.json as a checkpoint writes it: an object whose known keys have their types and ranges
// (next_frame, iterations: whole numbers >= 0; seconds: finite >= 0; dataset, poses, rng: strings;
// finished: true/false; timeline, keyframe_chunks: arrays or objects). Throws Error naming the file
// and the first key at fault, so a damaged state never becomes a wrapped-around frame number.
void validate_run_state(const nlohmann::json& state, const std::filesystem::path& file);
// The frame a resumed run continues at: a validated state's next_frame. Throws Error naming the file
// and the key when it is missing or lies beyond the dataset's `frames`.
size_t resume_frame(const nlohmann::json& state, const std::filesystem::path& file, size_t frames);

// Resident set size of this process now and its peak, in bytes (0 where /proc is unavailable).
uint64_t current_rss_bytes();
uint64_t peak_rss_bytes();

}  // namespace chungs
