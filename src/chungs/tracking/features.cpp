#include "chungs/tracking/features.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace chungs::tracking {

float level_scale(int octave, float scale_factor) { return std::pow(scale_factor, float(octave)); }

cv::Mat to_gray_mat(const Image8& img) {
  if (img.empty()) fail("tracking: empty image");
  cv::Mat m(img.height(), img.width(), CV_8UC(img.channels()), const_cast<uint8_t*>(img.data()));
  cv::Mat gray;
  if (img.channels() == 1) gray = m.clone();
  else if (img.channels() == 3) cv::cvtColor(m, gray, cv::COLOR_RGB2GRAY);
  else if (img.channels() == 4) cv::cvtColor(m, gray, cv::COLOR_RGBA2GRAY);
  else fail("tracking: image with ", img.channels(), " channels");
  return gray;
}

Features extract_orb(const cv::Mat& gray, const OrbOptions& opt) {
  if (gray.empty() || gray.type() != CV_8UC1) fail("extract_orb: need a non-empty 8-bit gray image");
  // Over-detect, then bucket: OpenCV's ORB alone clusters features on the most textured region.
  auto orb = cv::ORB::create(opt.features * 4, opt.scale_factor, opt.levels, 19, 0, 2, cv::ORB::FAST_SCORE, 31,
                             opt.fast_threshold);
  std::vector<cv::KeyPoint> all;
  orb->detect(gray, all);
  const int cols = std::max(1, gray.cols / opt.cell), rows = std::max(1, gray.rows / opt.cell);
  std::vector<std::vector<int>> bins(size_t(cols) * rows);
  for (int i = 0; i < int(all.size()); ++i) {
    int cx = std::min(cols - 1, int(all[i].pt.x / opt.cell)), cy = std::min(rows - 1, int(all[i].pt.y / opt.cell));
    bins[size_t(cy) * cols + cx].push_back(i);
  }
  for (auto& b : bins)
    std::sort(b.begin(), b.end(), [&](int a, int c) { return all[a].response > all[c].response; });
  // Round-robin over cells: every cell gives its best before any gives its second.
  std::vector<cv::KeyPoint> kept;
  kept.reserve(opt.features);
  for (size_t rank = 0; int(kept.size()) < opt.features; ++rank) {
    bool any = false;
    for (auto& b : bins) {
      if (rank >= b.size()) continue;
      any = true;
      kept.push_back(all[b[rank]]);
      if (int(kept.size()) >= opt.features) break;
    }
    if (!any) break;
  }
  Features f;
  orb->compute(gray, kept, f.desc);
  f.kps = std::move(kept);
  f.depth.assign(f.kps.size(), 0.f);
  f.u_right.assign(f.kps.size(), kNoRight);
  return f;
}

FeatureGrid::FeatureGrid(const std::vector<cv::KeyPoint>& kps, int width, int height, int cell)
    : cell_(cell), cols_(std::max(1, (width + cell - 1) / cell)), rows_(std::max(1, (height + cell - 1) / cell)) {
  const size_t cells = size_t(cols_) * rows_;
  std::vector<uint32_t> cell_of(kps.size());
  start_.assign(cells + 1, 0);
  for (size_t i = 0; i < kps.size(); ++i) {
    const int cx = std::clamp(int(kps[i].pt.x / cell), 0, cols_ - 1), cy = std::clamp(int(kps[i].pt.y / cell), 0, rows_ - 1);
    cell_of[i] = uint32_t(size_t(cy) * cols_ + cx);
    ++start_[cell_of[i] + 1];
  }
  for (size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
  entries_.resize(kps.size());
  std::vector<uint32_t> next(start_.begin(), start_.end() - 1);
  for (size_t i = 0; i < kps.size(); ++i)
    entries_[next[cell_of[i]]++] = Entry{kps[i].pt.x, kps[i].pt.y, kps[i].octave, int(i)};
}

void FeatureGrid::query(float u, float v, float radius, std::vector<int>& out, int min_octave, int max_octave) const {
  out.clear();
  int x0 = std::max(0, int(std::floor((u - radius) / cell_))), x1 = std::min(cols_ - 1, int(std::floor((u + radius) / cell_)));
  int y0 = std::max(0, int(std::floor((v - radius) / cell_))), y1 = std::min(rows_ - 1, int(std::floor((v + radius) / cell_)));
  if (x0 > x1 || y0 > y1) return;  // the disc lies off the image
  const float r2 = radius * radius;
  for (int y = y0; y <= y1; ++y) {
    const size_t row = size_t(y) * cols_;
    for (const Entry *e = entries_.data() + start_[row + x0], *end = entries_.data() + start_[row + x1 + 1]; e < end; ++e) {
      if (e->octave < min_octave || e->octave > max_octave) continue;
      const float du = e->x - u, dv = e->y - v;
      if (du * du + dv * dv <= r2) out.push_back(e->index);
    }
  }
}

int hamming(const uint8_t* a, const uint8_t* b) {
  const uint64_t* pa = reinterpret_cast<const uint64_t*>(a);
  const uint64_t* pb = reinterpret_cast<const uint64_t*>(b);
  int d = 0;
  for (int i = 0; i < 4; ++i) d += __builtin_popcountll(pa[i] ^ pb[i]);
  return d;
}

}  // namespace chungs::tracking
