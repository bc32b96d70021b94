#include "chungs/pipeline/timeline.hpp"

#include <charconv>
#include <cmath>
#include <sstream>

#include "chungs/common/error.hpp"

namespace chungs {

std::string timeline_csv(const std::vector<TimelineSample>& samples) {
  std::ostringstream s;
  s << "seconds,frame,keyframes,iterations,resident_gaussians,total_gaussians,chunks,rss_mb,chunk_loads,"
       "chunk_saves,"
       "chunk_io_ms,read_mb,written_mb,io_wait_ms,disk_mb,sampled,pruned,dropped_keyframes,checkpoint_ms,"
       "path_m,"
       "vram_used_mb\n";
  for (const auto& t : samples)
    s << t.seconds << ',' << t.frame << ',' << t.keyframes << ',' << t.iterations << ',' << t.resident << ','
      << t.total << ',' << t.chunks << ',' << t.rss_mb << ',' << t.loads << ',' << t.saves << ',' << t.io_ms
      << ',' << t.read_mb << ',' << t.written_mb << ',' << t.wait_ms << ',' << t.disk_mb << ',' << t.sampled
      << ',' << t.pruned << ',' << t.dropped << ',' << t.checkpoint_ms << ',' << t.path_m << ',' << t.vram_mb
      << '\n';
  return s.str();
}

namespace {

void append_number(TextPieces& out, double v) {
  if (!std::isfinite(v)) {  // as a JSON tree dumps it
    out += "null";
    return;
  }
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest text that reads back exactly
  out.append(std::string_view(buf, size_t(r.ptr - buf)));
}

void append_number(TextPieces& out, uint64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(std::string_view(buf, size_t(r.ptr - buf)));
}

}  // namespace

void append_json(TextPieces& out, const std::vector<TimelineSample>& samples) {
  out += '[';
  for (size_t i = 0; i < samples.size(); ++i) {
    const TimelineSample& t = samples[i];
    out += i ? ",[" : "[";
    bool first = true;
    auto put = [&](auto v) {
      if (!first) out += ',';
      first = false;
      append_number(out, v);
    };
    put(t.seconds), put(t.frame), put(t.keyframes), put(t.iterations), put(t.resident), put(t.total);
    put(t.chunks), put(t.rss_mb), put(t.loads), put(t.saves), put(t.io_ms), put(t.read_mb), put(t.written_mb);
    put(t.wait_ms), put(t.disk_mb), put(t.vram_mb), put(t.sampled), put(t.pruned), put(t.dropped);
    put(t.checkpoint_ms), put(t.path_m);
    out += ']';
  }
  out += ']';
}

nlohmann::json to_json(const std::vector<TimelineSample>& samples) {
  TextPieces text;
  append_json(text, samples);
  return nlohmann::json::parse(text.str());
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
