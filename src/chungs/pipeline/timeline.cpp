#include "chungs/pipeline/timeline.hpp"

#include <sstream>

#include "chungs/common/error.hpp"

namespace chungs {

std::string timeline_csv(const std::vector<TimelineSample>& samples) {
  std::ostringstream s;
  s << "seconds,frame,keyframes,iterations,resident_gaussians,total_gaussians,chunks,rss_mb,chunk_loads,"
       "chunk_saves,"
       "chunk_io_ms,read_mb,written_mb,io_wait_ms,disk_mb,sampled,pruned,dropped_keyframes,checkpoint_ms,path_m,"
       "vram_used_mb\n";
  for (const auto& t : samples)
    s << t.seconds << ',' << t.frame << ',' << t.keyframes << ',' << t.iterations << ',' << t.resident << ','
      << t.total << ',' << t.chunks << ',' << t.rss_mb << ',' << t.loads << ',' << t.saves << ',' << t.io_ms
      << ',' << t.read_mb << ',' << t.written_mb << ',' << t.wait_ms << ',' << t.disk_mb << ',' << t.sampled
      << ',' << t.pruned << ',' << t.dropped << ',' << t.checkpoint_ms << ',' << t.path_m << ',' << t.vram_mb
      << '\n';
  return s.str();
}

nlohmann::json to_json(const std::vector<TimelineSample>& samples) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& t : samples)
    a.push_back({t.seconds, t.frame, t.keyframes, t.iterations, t.resident, t.total, t.chunks, t.rss_mb,
                 t.loads, t.saves, t.io_ms, t.read_mb, t.written_mb, t.wait_ms, t.disk_mb, t.vram_mb, t.sampled,
                 t.pruned, t.dropped, t.checkpoint_ms, t.path_m});
  return a;
}

std::vector<TimelineSample> timeline_from_json(const nlohmann::json& j) {
  std::vector<TimelineSample> out;
  if (!j.is_array()) return out;
  for (const auto& r : j) {
    // Older versions wrote 11 fields (before the I/O columns), 15 (before VRAM) or 16 (before the
    // pacing columns); a map resumed from one of them reads the missing fields as 0.
    if (!r.is_array() || (r.size() != 11 && r.size() != 15 && r.size() != 16 && r.size() != 21))
      fail("timeline: a sample must have 21 (or 16, 15 or 11) fields, got ", r.dump());
    TimelineSample t;
    t.seconds = r[0];
    t.frame = r[1];
    t.keyframes = r[2];
    t.iterations = r[3];
    t.resident = r[4];
    t.total = r[5];
    t.chunks = r[6];
    t.rss_mb = r[7];
    t.loads = r[8];
    t.saves = r[9];
    t.io_ms = r[10];
    if (r.size() >= 15) {
      t.read_mb = r[11];
      t.written_mb = r[12];
      t.wait_ms = r[13];
      t.disk_mb = r[14];
    }
    if (r.size() >= 16) t.vram_mb = r[15];
    if (r.size() >= 21) {
      t.sampled = r[16];
      t.pruned = r[17];
      t.dropped = r[18];
      t.checkpoint_ms = r[19];
      t.path_m = r[20];
    }
    out.push_back(t);
  }
  return out;
}

}  // namespace chungs
