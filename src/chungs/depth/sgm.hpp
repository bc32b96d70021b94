// Semi-global matching of a rectified pair: census costs over a 9x7 window, costs aggregated along
// four scanline directions, the winner per left pixel with a uniqueness test and a sub-pixel
// parabola, and the right view's winners from the same aggregated costs (for the left-right
// check). All integer arithmetic, so the CUDA kernels (depth/cuda/sgm.cu) compute the same numbers
// bit for bit; the loops here are their CPU twin and the stereo of runs without a GPU.
#pragma once
#include <cstdint>
#include <vector>

#include "chungs/image/image.hpp"

namespace chungs {

struct SgmParams {
  int disparities = 128;  // candidates 0 .. disparities-1 (at most kSgmMaxDisparities)
  int p1 = 10;            // penalty of a one-pixel disparity change between neighbours
  int p2 = 120;           // penalty of a larger change (census costs are 0..62)
  int uniqueness = 10;    // percent by which the best cost must beat any other outside +-1 pixel
  void validate() const;
};

constexpr int kSgmMaxDisparities = 256;
constexpr int16_t kNoDisparity = -16;  // in the x16 maps: no unique winner
constexpr int kSgmOutsideCost = 64;    // a candidate whose match lies left of the right image

struct SgmDisparities {
  int width = 0, height = 0;
  std::vector<int16_t> left;   // x16 disparity of each left pixel (sub-pixel), kNoDisparity where none
  std::vector<int16_t> right;  // x16 disparity of each right pixel (whole pixels): argmin_d S(x + d, d)
};

// Gray images of one size. Throws Error on empty or mismatched images or invalid params.
SgmDisparities sgm_disparities(const Image8& left, const Image8& right, const SgmParams& params);
void check_sgm_inputs(const Image8& left, const Image8& right, const SgmParams& params);  // the throws above

#ifdef __CUDACC__
#define CHUNGS_SGM_HOST_DEVICE __host__ __device__
#else
#define CHUNGS_SGM_HOST_DEVICE
#endif

// Census signature of each pixel: one bit per neighbour of the 9x7 window (row by row, the centre
// skipped), set where the neighbour is darker; neighbours outside the image give 0.
std::vector<uint64_t> census_9x7(const Image8& gray);
// Rounded (half up) x16 offset of the parabola through the costs at d-1, d, d+1 (a, b, c with
// a, c >= b): always within [-8, 8].
CHUNGS_SGM_HOST_DEVICE inline int sgm_subpixel_offset(int a, int b, int c) {
  const int den = (a + c - 2 * b) > 1 ? (a + c - 2 * b) : 1;
  const int num = (a - c) * 16;
  return (num + den + 32 * den) / (2 * den) - 16;  // shifted positive so division floors
}

}  // namespace chungs
