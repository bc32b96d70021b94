#include "chungs/pipeline/ply_export.hpp"

#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/common/progress.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/chunk_levels.hpp"

namespace chungs {

namespace {

// The header is written last, once the count is known, over room left for it at the start of the
// file: a comment pads it to the length it has with the largest count, so the rows need not be held.
std::string header(uint64_t n) {
  std::string h = "ply\nformat binary_little_endian 1.0\ncomment DiskChunGS map";
  const std::string rest = "\nelement vertex " + std::to_string(n) + "\n";
  std::string props;
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"})
    props += std::string("property float ") + p + "\n";
  for (int i = 0; i < 45; ++i) props += "property float f_rest_" + std::to_string(i) + "\n";
  props += "property float opacity\n";
  for (int i = 0; i < 3; ++i) props += "property float scale_" + std::to_string(i) + "\n";
  for (int i = 0; i < 4; ++i) props += "property float rot_" + std::to_string(i) + "\n";
  const size_t digits = std::to_string(n).size(), most = std::to_string(UINT64_MAX).size();
  h.append(most - digits, ' ');
  return h + rest + props + "end_header\n";
}

void append_row(const GaussianParams& p, size_t i, std::vector<float>& row) {
  for (int k = 0; k < 3; ++k) row.push_back(p.mean[3 * i + k]);
  row.insert(row.end(), {0.f, 0.f, 0.f});
  for (int c = 0; c < 3; ++c) row.push_back(p.sh[48 * i + c]);
  for (int c = 0; c < 3; ++c)
    for (int k = 1; k < kShCoeffs; ++k) row.push_back(p.sh[48 * i + 3 * k + c]);
  row.push_back(p.opacity[i]);
  for (int k = 0; k < 3; ++k) row.push_back(p.log_scale[3 * i + k]);
  for (int k = 0; k < 4; ++k) row.push_back(p.rotation[4 * i + k]);
}

static_assert(sizeof(float) == 4);

bool finite_gaussian(const GaussianParams& p, size_t i) {
  bool ok = std::isfinite(p.opacity[i]);
  for (int k = 0; k < 3; ++k) ok = ok && std::isfinite(p.mean[3 * i + k]) && std::isfinite(p.log_scale[3 * i + k]);
  for (int k = 0; k < 4; ++k) ok = ok && std::isfinite(p.rotation[4 * i + k]);
  for (int k = 0; k < 48; ++k) ok = ok && std::isfinite(p.sh[48 * i + k]);
  return ok;
}

bool in_box(const GaussianParams& p, size_t i, const PlySelection& s) {
  if (!s.box_lo) return true;
  for (int k = 0; k < 3; ++k)
    if (p.mean[3 * i + k] < (*s.box_lo)[k] || p.mean[3 * i + k] > (*s.box_hi)[k]) return false;
  return true;
}

// Rows are streamed to a temporary file renamed over `file` once complete: a failed export (a
// damaged chunk, a full disk) leaves no file, or the one that was there, never a partial one.
// `blocks(add)` calls add(params, i) for every Gaussian in order.
using AddRow = std::function<void(const GaussianParams&, size_t)>;
uint64_t write_ply(const std::filesystem::path& file, const std::function<void(const AddRow&)>& blocks) {
  prepare_output_file(file, "PLY file");
  std::string head = header(0);  // its length; the text is written over once the count is known
  uint64_t n = 0;
  write_file_atomically(
      file, {head.data(), head.size()},
      [&](const Append& append) {
        constexpr size_t kFlushFloats = size_t(1) << 18;  // 1 MiB a write
        std::vector<float> rows;
        rows.reserve(kFlushFloats + 62);
        blocks([&](const GaussianParams& p, size_t i) {
          append_row(p, i, rows);
          ++n;
          if (rows.size() >= kFlushFloats) append(rows.data(), rows.size() * sizeof(float)), rows.clear();
        });
        append(rows.data(), rows.size() * sizeof(float));
        const std::string h = header(n);
        head.replace(0, h.size(), h);  // the same length: the buffer handed over stays where it is
      },
      false);
  return n;
}

}  // namespace

void write_gaussian_ply(const std::filesystem::path& file, const std::vector<const GaussianBlock*>& blocks) {
  write_ply(file, [&](const AddRow& add) {
    for (const GaussianBlock* b : blocks)
      for (size_t i = 0; i < b->size(); ++i) add(b->params, i);
  });
}

uint64_t export_ply(const ChunkStore& store, const std::filesystem::path& file, const PlySelection& select) {
  if (select.box_lo.has_value() != select.box_hi.has_value()) fail("export: a box needs both corners");
  // A PLY's viewer draws every splat from wherever it looks: each cube at its near level, or its far
  // one where it has no other.
  std::vector<ChunkId> ids;
  if (select.chunk) {
    const ChunkId near = near_level_of(*select.chunk);
    if (store.contains(near)) ids.push_back(near);
    else if (store.contains(far_level_of(near))) ids.push_back(far_level_of(near));
    else fail("export: the map has no ", chunk_name(near));
  } else {
    for (ChunkId id : store.ids()) {
      if (far_level_with_near_twin(store, id)) continue;
      if (select.box_lo) {
        Eigen::Vector3d lo, hi;
        chunk_box(chunk_coord(id), store.chunk_size(), lo, hi);
        if ((hi.array() < select.box_lo->array()).any() || (lo.array() > select.box_hi->array()).any()) continue;
      }
      ids.push_back(id);
    }
  }
  // A 10 km map is thousands of chunk files read and converted: say how far the export is.
  Progress progress("exporting chunks", (long long)ids.size());
  // A chunk file that passed its checksum may still hold nan or inf (written so by a faulty writer):
  // viewers choke on such rows, so they are left out and counted.
  uint64_t non_finite = 0;
  std::optional<ChunkId> first_bad;
  const uint64_t n = write_ply(file, [&](const AddRow& add) {
    for (ChunkId id : ids) {
      const GaussianBlock b = store.load(id);
      for (size_t i = 0; i < b.size(); ++i) {
        if (!in_box(b.params, i, select)) continue;
        if (!finite_gaussian(b.params, i)) {
          ++non_finite;
          if (!first_bad) first_bad = id;
          continue;
        }
        add(b.params, i);
      }
      progress.step();
    }
  });
  if (non_finite)
    log::warn(store.folder().string(), ": ", non_finite, " Gaussians hold nan or infinite values (the first in ",
              chunk_name(*first_bad), "); they were left out of ", file.string(), ": the map is damaged");
  return n;
}

}  // namespace chungs
