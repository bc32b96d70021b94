#include "chungs/datasets/reader_common.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "chungs/common/text_file.hpp"
#include "chungs/image/image_io.hpp"

namespace chungs::ds {

double SequenceDataset::timestamp(size_t i) const {
  check_index(i);
  return stamps_[i];
}

std::optional<SE3> SequenceDataset::gt_pose(size_t i) const {
  check_index(i);
  if (gt_.empty()) return std::nullopt;
  return gt_[i];
}

void SequenceDataset::finish(std::vector<double> stamps, std::vector<std::optional<SE3>> gt) {
  if (stamps.empty()) fail(info_.path.string(), ": ", info_.kind, " dataset has no frames");
  if (!gt.empty() && gt.size() != stamps.size())
    fail(info_.path.string(), ": ", gt.size(), " ground-truth entries for ", stamps.size(), " frames");
  stamps_ = std::move(stamps);
  gt_ = std::move(gt);
  info_.frames = stamps_.size();
  info_.has_gt = std::any_of(gt_.begin(), gt_.end(), [](const auto& p) { return p.has_value(); });
  if (!info_.has_gt) gt_.clear();
}

void SequenceDataset::check_index(size_t i) const {
  if (i >= stamps_.size())
    fail(info_.kind, ":", info_.path.string(), ": frame ", i, " is out of range (", stamps_.size(), " frames)");
}

Frame SequenceDataset::frame_header(size_t i, const fs::path& source) const {
  check_index(i);
  Frame f;
  f.index = i;
  f.timestamp = stamps_[i];
  if (!gt_.empty()) f.gt_pose = gt_[i];
  f.camera = info_.camera;
  f.baseline = info_.baseline;
  f.source = source.string();
  return f;
}

std::vector<std::pair<long long, fs::path>> numbered_files(const fs::path& dir, const std::string& prefix,
                                                           const std::string& suffix) {
  require_dir(dir, "image folder");
  std::vector<std::pair<long long, fs::path>> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    std::string name = e.path().filename().string();
    if (name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    std::string mid = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
    // More than 18 digits would overflow; such names are not frame numbers.
    if (mid.size() > 18 || !std::all_of(mid.begin(), mid.end(), [](unsigned char c) { return std::isdigit(c); }))
      continue;
    out.emplace_back(std::stoll(mid), e.path());
  }
  if (ec) fail(dir.string(), ": cannot list folder (", ec.message(), ")");
  std::sort(out.begin(), out.end());
  for (size_t i = 1; i < out.size(); ++i)
    if (out[i].first == out[i - 1].first)
      fail(out[i].second.string(), ": same frame number as ", out[i - 1].second.filename().string());
  return out;
}

fs::path named_folder(const fs::path& p) {
  fs::path n = p.lexically_normal();
  return n.has_filename() ? n : n.parent_path();
}

fs::path folder_with(const fs::path& dir, const std::string& child, const std::string& what) {
  require_dir(dir, what);
  std::error_code ec;
  if (fs::exists(dir / child, ec)) return dir;
  // Given the child folder itself (SEQ/results for SEQ): its parent is the sequence.
  if (const fs::path named = named_folder(dir); named.filename() == child && named.has_parent_path())
    return named.parent_path();
  std::vector<fs::path> hits;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_directory() && fs::exists(e.path() / child, ec)) hits.push_back(e.path());
  if (hits.empty()) fail(dir.string(), ": not a ", what, " (no ", child, " in it or in a subfolder)");
  if (hits.size() > 1) {
    std::sort(hits.begin(), hits.end());
    fail(dir.string(), ": several ", what, "s inside (", hits[0].filename().string(), ", ",
         hits[1].filename().string(), ", ...); name one of them");
  }
  return hits[0];
}

std::optional<fs::path> first_existing(const std::vector<fs::path>& candidates) {
  std::error_code ec;
  for (const auto& p : candidates)
    if (fs::is_regular_file(p, ec)) return p;
  return std::nullopt;
}

Image8 load_image(const fs::path& file, int width, int height, int channels) {
  Image8 img = read_image8(file);
  if (width > 0 && (img.width() != width || img.height() != height))
    fail(file.string(), ": image is ", img.width(), "x", img.height(), ", expected ", width, "x", height,
         " like the rest of the sequence");
  if (img.channels() == 4) {
    // Alpha carries nothing for tracking or mapping; keep RGB.
    Image8 rgb(img.width(), img.height(), 3);
    for (size_t p = 0; p < img.pixels(); ++p)
      for (int c = 0; c < 3; ++c) rgb.data()[p * 3 + c] = img.data()[p * 4 + c];
    img = std::move(rgb);
  }
  if (channels > 0 && img.channels() != channels)
    fail(file.string(), ": image has ", img.channels(), " channels, expected ", channels,
         " like the first image of the sequence");
  return img;
}

ImageF load_depth(const fs::path& file, double units_per_metre, int width, int height) {
  Image16 raw = read_png16(file);
  if (raw.width() != width || raw.height() != height)
    fail(file.string(), ": depth map is ", raw.width(), "x", raw.height(), ", expected ", width, "x", height,
         " like the colour images");
  ImageF depth(width, height, 1);
  const float inv = float(1.0 / units_per_metre);
  for (size_t p = 0; p < raw.pixels(); ++p) depth.data()[p] = float(raw.data()[p]) * inv;
  return depth;
}

Eigen::MatrixXd read_matrix(const fs::path& file, int rows, int cols) {
  auto lines = read_text_table(file);
  if (int(lines.size()) != rows)
    fail(file.string(), ": expected ", rows, " rows of ", cols, " numbers, found ", lines.size(), " rows");
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r) {
    lines[r].expect_fields(size_t(cols));
    for (int c = 0; c < cols; ++c) m(r, c) = lines[r].number_at(size_t(c));
  }
  return m;
}

std::vector<std::optional<SE3>> poses_at(const Trajectory& gt, const std::vector<double>& stamps, double max_dt) {
  std::vector<std::optional<SE3>> out(stamps.size());
  const auto& ts = gt.stamps;
  for (size_t i = 0; i < stamps.size(); ++i) {
    double t = stamps[i];
    size_t hi = size_t(std::lower_bound(ts.begin(), ts.end(), t) - ts.begin());
    bool has_lo = hi > 0 && t - ts[hi - 1] <= max_dt;
    bool has_hi = hi < ts.size() && ts[hi] - t <= max_dt;
    if (has_lo && has_hi && ts[hi] > ts[hi - 1]) {
      const SE3& a = gt.poses[hi - 1];
      const SE3& b = gt.poses[hi];
      double s = (t - ts[hi - 1]) / (ts[hi] - ts[hi - 1]);
      out[i] = SE3(a.q.slerp(s, b.q), (1 - s) * a.t + s * b.t);
    } else if (has_lo && (!has_hi || t - ts[hi - 1] <= ts[hi] - t)) {
      out[i] = gt.poses[hi - 1];
    } else if (has_hi) {
      out[i] = gt.poses[hi];
    }
  }
  return out;
}

double require_positive(double v, const fs::path& file, const std::string& what) {
  if (!(std::isfinite(v) && v > 0)) fail(file.string(), ": ", what, " must be positive, got ", v);
  return v;
}

int require_pixels(double v, const fs::path& file, const std::string& what) {
  if (!(v >= 1 && v <= double(kMaxImagePixels) && v == std::floor(v)))
    fail(file.string(), ": ", what, " must be a whole number of pixels in [1, ", kMaxImagePixels, "], got ",
         v);
  return int(v);
}

}  // namespace chungs::ds
