// ORB features spread over an image grid, with the per-feature depth a stereo pair or a depth map gives.
#pragma once
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "chungs/image/image.hpp"

namespace chungs::tracking {

struct OrbOptions {
  int features = 2000;      // kept after grid bucketing
  int levels = 8;           // pyramid levels
  float scale_factor = 1.2f;
  int fast_threshold = 12;  // low on purpose: the grid keeps only the strongest per cell
  int cell = 32;            // grid cell in pixels (level 0)
};

// Keypoints of one image with descriptors and, when known, depth and the (real or virtual) right-image
// column u_r = u - bf / depth that stereo residuals use.
struct Features {
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;                 // N x 32, CV_8U
  std::vector<float> depth;     // metres, 0 when unknown
  std::vector<float> u_right;   // pixels, negative when unknown
  size_t size() const { return kps.size(); }
  bool has_depth(size_t i) const { return depth[i] > 0; }
};

// Scale of pyramid level `octave` relative to level 0.
// "No right column" for u_right. Not -1: an RGB-D virtual baseline makes real right columns negative
// (u - bf / z < 0) for features left of bf / z, and those lost their depth row.
constexpr float kNoRight = -1e9f;
inline bool has_right(double ur) { return ur > -1e8; }

float level_scale(int octave, float scale_factor = 1.2f);

// 8-bit gray cv::Mat sharing nothing with the input (RGB is converted to luma).
cv::Mat to_gray_mat(const Image8& img);

// Detects ORB corners, keeps the strongest per grid cell (so texture-rich regions do not take all the
// features), computes descriptors; depth/u_right are sized and left unknown.
Features extract_orb(const cv::Mat& gray, const OrbOptions& opt);

// Lookup grid over keypoint positions for radius queries.
class FeatureGrid {
 public:
  FeatureGrid(const std::vector<cv::KeyPoint>& kps, int width, int height, int cell = 16);
  // Indices of keypoints within `radius` pixels of (u, v) whose octave is in [min_octave, max_octave].
  void query(float u, float v, float radius, std::vector<int>& out, int min_octave = 0, int max_octave = 99) const;

 private:
  // A cell's keypoints lie together, in index order, with what a query tests: one array for all cells
  // instead of a vector each (thousands of allocations a grid) and no detour through cv::KeyPoint.
  struct Entry {
    float x, y;
    int octave, index;
  };
  int cell_, cols_, rows_;
  std::vector<uint32_t> start_;  // cell c holds entries_[start_[c], start_[c + 1])
  std::vector<Entry> entries_;
};

// Hamming distance between two 32-byte ORB descriptors.
int hamming(const uint8_t* a, const uint8_t* b);

}  // namespace chungs::tracking
