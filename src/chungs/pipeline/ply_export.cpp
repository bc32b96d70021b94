#include "chungs/pipeline/ply_export.hpp"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include "chungs/common/error.hpp"

namespace chungs {

namespace {

std::string header(uint64_t n) {
  std::string h = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n) + "\n";
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"})
    h += std::string("property float ") + p + "\n";
  for (int i = 0; i < 45; ++i) h += "property float f_rest_" + std::to_string(i) + "\n";
  h += "property float opacity\n";
  for (int i = 0; i < 3; ++i) h += "property float scale_" + std::to_string(i) + "\n";
  for (int i = 0; i < 4; ++i) h += "property float rot_" + std::to_string(i) + "\n";
  return h + "end_header\n";
}

void append_row(const GaussianParams& p, size_t i, std::vector<float>& row) {
  row.clear();
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

bool in_box(const GaussianParams& p, size_t i, const PlySelection& s) {
  if (!s.box_lo) return true;
  for (int k = 0; k < 3; ++k)
    if (p.mean[3 * i + k] < (*s.box_lo)[k] || p.mean[3 * i + k] > (*s.box_hi)[k]) return false;
  return true;
}

class PlyWriter {
 public:
  explicit PlyWriter(const std::filesystem::path& file) : file_(file) {
    if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path());
    out_.open(file, std::ios::binary);
    if (!out_) fail(file.string(), ": cannot create the PLY file");
    out_ << header(0) ;  // rewritten with the final count
  }
  void add(const GaussianParams& p, size_t i) {
    append_row(p, i, row_);
    body_.insert(body_.end(), row_.begin(), row_.end());
    ++n_;
  }
  uint64_t finish() {
    out_.seekp(0);
    const std::string h = header(n_);
    out_.write(h.data(), std::streamsize(h.size()));
    out_.write(reinterpret_cast<const char*>(body_.data()), std::streamsize(body_.size() * sizeof(float)));
    out_.close();
    if (!out_) fail(file_.string(), ": write failed (disk full?)");
    return n_;
  }

 private:
  std::filesystem::path file_;
  std::ofstream out_;
  std::vector<float> row_, body_;
  uint64_t n_ = 0;
};

}  // namespace

void write_gaussian_ply(const std::filesystem::path& file, const std::vector<const GaussianBlock*>& blocks) {
  PlyWriter w(file);
  for (const GaussianBlock* b : blocks)
    for (size_t i = 0; i < b->size(); ++i) w.add(b->params, i);
  w.finish();
}

uint64_t export_ply(const ChunkStore& store, const std::filesystem::path& file, const PlySelection& select) {
  if (select.box_lo.has_value() != select.box_hi.has_value()) fail("export: a box needs both corners");
  std::vector<ChunkId> ids;
  if (select.chunk) {
    if (!store.contains(*select.chunk)) fail("export: the map has no chunk ", chunk_name(*select.chunk));
    ids.push_back(*select.chunk);
  } else {
    for (ChunkId id : store.ids()) {
      if (select.box_lo) {
        Eigen::Vector3d lo, hi;
        chunk_box(chunk_coord(id), store.chunk_size(), lo, hi);
        if ((hi.array() < select.box_lo->array()).any() || (lo.array() > select.box_hi->array()).any()) continue;
      }
      ids.push_back(id);
    }
  }
  PlyWriter w(file);
  for (ChunkId id : ids) {
    const GaussianBlock b = store.load(id);
    for (size_t i = 0; i < b.size(); ++i)
      if (in_box(b.params, i, select)) w.add(b.params, i);
  }
  return w.finish();
}

}  // namespace chungs
