#include "chungs/mapping/map_state.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "chungs/common/text_file.hpp"
#include "chungs/gaussians/gaussian_block.hpp"
#include "chungs/image/image.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/chunk_id.hpp"
#include "chungs/store/manifest.hpp"

namespace chungs {

void append_keyframe_records_header(TextPieces& out) {
  out += "# id frame stamp width height fx fy cx cy tx ty tz qx qy qz qw uses last_loss\n";
}

void append_keyframe_record(TextPieces& out, const KeyframeRecord& r) {
  thread_local std::ostringstream s;
  s.str("");
  s.precision(17);
  const auto& c = r.camera;
  s << r.id << ' ' << r.frame << ' ' << r.stamp << ' ' << c.width << ' ' << c.height << ' ' << c.fx << ' '
    << c.fy << ' ' << c.cx << ' ' << c.cy << ' ' << r.pose.t.x() << ' ' << r.pose.t.y() << ' ' << r.pose.t.z()
    << ' ' << r.pose.q.x() << ' ' << r.pose.q.y() << ' ' << r.pose.q.z() << ' ' << r.pose.q.w() << ' '
    << r.uses << ' ' << r.last_loss << '\n';
  out += s.view();
}

void write_keyframe_records(const std::filesystem::path& file, const std::vector<KeyframeRecord>& records,
                            bool durable) {
  write_text_atomically(file, keyframe_records_text(records), durable);
}

std::vector<KeyframeRecord> read_keyframe_records(const std::filesystem::path& file) {
  std::vector<KeyframeRecord> out;
  const std::string text = read_file_text(file);
  std::istringstream in(text);
  std::string line;
  size_t lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    KeyframeRecord r;
    double t[3], q[4];
    ls >> r.id >> r.frame >> r.stamp >> r.camera.width >> r.camera.height >> r.camera.fx >> r.camera.fy >>
        r.camera.cx >> r.camera.cy >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3] >> r.uses >>
        r.last_loss;
    const std::string where = cat(file.string(), ":", lineno);
    if (!ls) fail(where, ": expected 18 numbers (a keyframe record)");
    // The writer stores unit quaternions; a zero one would normalise to NaNs and render nothing.
    const Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
    if (!(std::abs(rotation.norm() - 1) <= 1e-2))
      fail(where, ": quaternion (", q[0], ", ", q[1], ", ", q[2], ", ", q[3], ") is not unit length (norm ",
           rotation.norm(), ")");
    r.pose = SE3(rotation.normalized(), Eigen::Vector3d(t[0], t[1], t[2]));
    r.camera.validate(where);
    // Renders and keyframe images are allocated at this size: no more than an image file may hold.
    if (uint64_t(r.camera.width) * uint64_t(r.camera.height) > kMaxImagePixels)
      fail(where, ": image size ", r.camera.width, "x", r.camera.height, " is more than the ",
           kMaxImagePixels, " pixels an image may have");
    out.push_back(r);
  }
  return out;
}

std::filesystem::path checkpoint_file(const std::filesystem::path& folder, uint64_t seq,
                                      const std::string& final_name) {
  return folder / cat("checkpoint-", seq, "-", final_name);
}

bool holds_a_map(const std::filesystem::path& folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(folder / "keyframes.txt", ec)) return true;
  if (!fs::exists(folder / "manifest.txt", ec)) return false;
  try {
    const Manifest m = Manifest::read(folder / "manifest.txt");
    return !m.chunks.empty() || m.config.count("checkpoint") > 0;
  } catch (const Error&) {
    return true;
  }
}

void require_folder_for_new_map(const std::filesystem::path& folder) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return;  // made by the store, or refused there (a file)
  static const std::set<std::string> made_by_a_run = {
      "chunks",      "keyframes",  "lock",      "manifest.txt", "keyframes.txt", "sky.bin",
      "run_state.json", "report.json", "timeline.csv", "memory.png", "trajectory.txt", "renders"};
  std::vector<std::string> all, other;
  for (const fs::directory_entry& e : fs::directory_iterator(folder)) {
    const std::string name = e.path().filename().string();
    all.push_back(name);
    if (!made_by_a_run.count(name) && name.rfind("checkpoint-", 0) != 0 && name.find(".tmp-") == std::string::npos)
      other.push_back(name);
  }
  // A run's leftover has its chunk folder (the store makes it before anything else); without it, files
  // of a run's names alone are the user's too.
  if (other.empty() && std::find(all.begin(), all.end(), "chunks") == all.end()) other = all;
  if (other.empty()) return;
  std::sort(other.begin(), other.end());
  std::string names;
  for (size_t i = 0; i < other.size() && i < 3; ++i) names += (i ? ", " : "") + other[i];
  if (other.size() > 3) names += cat(" and ", other.size() - 3, " more");
  fail(folder.string(), " holds files and no map (", names,
       "): a new map goes into a new or empty folder, so that none of them is written over");
}

std::filesystem::path committed_file(const std::filesystem::path& folder, uint64_t seq,
                                     const std::string& final_name) {
  const std::filesystem::path pending = checkpoint_file(folder, seq, final_name);
  std::error_code ec;
  return seq > 0 && std::filesystem::exists(pending, ec) ? pending : folder / final_name;
}

void write_json_atomically(const std::filesystem::path& file, const nlohmann::json& j, bool durable) {
  write_text_atomically(file, j.dump(1) + "\n", durable);
}

void write_text_atomically(const std::filesystem::path& file, const std::string& text, bool durable) {
  const ConstBuffer part{text.data(), text.size()};
  write_file_atomically(file, std::span<const ConstBuffer>(&part, 1), durable);
}

void write_text_atomically(const std::filesystem::path& file, const TextPieces& text, bool durable) {
  std::vector<ConstBuffer> parts;
  parts.reserve(text.pieces().size());
  for (const std::string& p : text.pieces()) parts.push_back({p.data(), p.size()});
  write_file_atomically(file, parts, durable);
}

nlohmann::json read_json_file(const std::filesystem::path& file) {
  const std::string text = read_file_text(file);
  require_json_nesting(text, file);
  try {
    return nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    fail(file.string(), ": not valid JSON (", e.what(), ")");
  }
}

void validate_run_state(const nlohmann::json& j, const std::filesystem::path& file) {
  auto bad = [&](const char* key, const std::string& what) {
    // A damaged value may be megabytes: the message shows its start.
    std::string got = j[key].dump();
    if (got.size() > 80) got = got.substr(0, 80) + "... (" + std::to_string(got.size()) + " characters)";
    fail(file.string(), ": '", key, "' must be ", what, ", got ", got);
  };
  if (!j.is_object()) fail(file.string(), ": not a run state (a JSON object), got ", j.type_name());
  for (const char* key : {"next_frame", "iterations", "frames", "holdout_every"})
    if (j.contains(key) && !j[key].is_number_unsigned()) bad(key, "a whole number >= 0");
  if (j.contains("seconds") && !(j["seconds"].is_number() && std::isfinite(j["seconds"].get<double>()) &&
                                 j["seconds"].get<double>() >= 0))
    bad("seconds", "a finite number >= 0");
  for (const char* key : {"dataset", "poses", "rng"})
    if (j.contains(key) && !j[key].is_string()) bad(key, "a string");
  if (j.contains("finished") && !j["finished"].is_boolean()) bad("finished", "true or false");
  for (const char* key : {"timeline", "keyframe_chunks"})
    if (j.contains(key) && !(j[key].is_array() || j[key].is_object())) bad(key, "an array or object");
  if (j.contains("next_frame") && j.contains("frames") && j["next_frame"].get<uint64_t>() > j["frames"].get<uint64_t>())
    fail(file.string(), ": 'next_frame' ", j["next_frame"].dump(), " lies beyond its 'frames' ", j["frames"].dump());
  // The map's geometry, which a lost manifest is rebuilt with (Mapper), and the keyframe list's size.
  auto number_in = [&](const char* key, double lo, double hi) {
    return j[key].is_number() && j[key].get<double>() >= lo && j[key].get<double>() <= hi;
  };
  if (j.contains("chunk_size") && !number_in("chunk_size", kMinChunkSize, kMaxChunkSize))
    bad("chunk_size", cat("a chunk size in [", kMinChunkSize, ", ", kMaxChunkSize, "] metres"));
  if (j.contains("sh_degree") && !(j["sh_degree"].is_number_unsigned() && j["sh_degree"].get<uint64_t>() <= kMaxShDegree))
    bad("sh_degree", cat("a whole number in [0, ", kMaxShDegree, "]"));
  if (j.contains("far_level_distance") && !number_in("far_level_distance", 0, 1e6))
    bad("far_level_distance", "0 or a positive number of metres");
  if (j.contains("keyframe_list")) {
    const nlohmann::json& k = j["keyframe_list"];
    if (!k.is_object() || !k.contains("count") || !k["count"].is_number_unsigned() || !k.contains("last_id") ||
        !k["last_id"].is_number_unsigned())
      bad("keyframe_list", "an object of two whole numbers, count and last_id");
  }
}

size_t resume_frame(const nlohmann::json& state, const std::filesystem::path& file, size_t frames) {
  // Every checkpoint of a run writes it; without it the run would map the dataset again from frame 0
  // on top of the map. (Its type was checked by validate_run_state.)
  if (!state.contains("next_frame"))
    fail(file.string(), ": 'next_frame' is missing, so --resume cannot tell where the run stopped");
  const size_t next = state["next_frame"].get<size_t>();
  if (next > frames)
    fail(file.string(), ": 'next_frame' ", next, " lies beyond the dataset's ", frames, " frames");
  return next;
}

namespace {
uint64_t status_kb(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  const std::string k = key;
  while (std::getline(f, line))
    if (line.rfind(k, 0) == 0) return std::stoull(line.substr(k.size())) * 1024;
  return 0;
}
}  // namespace

uint64_t current_rss_bytes() { return status_kb("VmRSS:"); }
uint64_t peak_rss_bytes() { return status_kb("VmHWM:"); }

}  // namespace chungs
