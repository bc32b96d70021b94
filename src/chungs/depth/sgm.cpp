#include "chungs/depth/sgm.hpp"

#include <algorithm>
#include <memory>

#include "chungs/common/error.hpp"

namespace chungs {

void SgmParams::validate() const {
  if (disparities < 1 || disparities > kSgmMaxDisparities)
    fail("stereo matching: disparities must be in [1, ", kSgmMaxDisparities, "], got ", disparities);
  if (p1 < 0 || p2 < p1 || p2 > 1000) fail("stereo matching: need 0 <= p1 <= p2 <= 1000, got ", p1, " and ", p2);
  if (uniqueness < 0 || uniqueness > 100) fail("stereo matching: uniqueness must be in [0, 100] %, got ", uniqueness);
}

void check_sgm_inputs(const Image8& left, const Image8& right, const SgmParams& params) {
  params.validate();
  if (left.empty() || !left.same_size(right) || left.channels() != 1 || right.channels() != 1)
    fail("stereo matching: need two gray images of one size, got ", left.width(), "x", left.height(), "x",
         left.channels(), " and ", right.width(), "x", right.height(), "x", right.channels());
}

std::vector<uint64_t> census_9x7(const Image8& gray) {
  const int w = gray.width(), h = gray.height();
  std::vector<uint64_t> out(size_t(w) * size_t(h));
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint8_t c = gray(x, y);
      uint64_t bits = 0;
      // Neighbours outside the image count as not darker (bit 0).
      for (int dy = -3; dy <= 3; ++dy)
        for (int dx = -4; dx <= 4; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const int xx = x + dx, yy = y + dy;
          const bool darker = xx >= 0 && xx < w && yy >= 0 && yy < h && gray(xx, yy) < c;
          bits = (bits << 1) | uint64_t(darker);
        }
      out[size_t(y) * w + x] = bits;
    }
  return out;
}

namespace {

// The cost volume and the path sums (3.7 and 7.5 MB at 310x94 with 128 disparities), kept by each
// thread that matches. Allocated per call, they left holes in the heap that the smaller allocations
// made meanwhile (and kept) took, so that the next pair needed new heap: host RSS of the 10 km drive
// kept stepping up after the map's budget was full (bench/README.md). The mapper matches on a
// fixed set of keyframe loaders, so this is a few such buffers for the whole run.
struct SgmScratch {
  std::vector<uint8_t> cost;
  std::vector<uint16_t> sum;
};
SgmScratch& sgm_scratch() {
  thread_local SgmScratch s;
  return s;
}

// Hot loops get an AVX2/POPCNT build beside the baseline one, picked at load time by the CPU.
#define CHUNGS_SGM_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))

CHUNGS_SGM_CLONES void census_costs(const uint64_t* cl, const uint64_t* cr, int w, int D, uint8_t* cost) {
  for (int x = 0; x < w; ++x)
    for (int d = 0; d < D; ++d)
      cost[size_t(x) * D + d] = x - d >= 0 ? uint8_t(__builtin_popcountll(cl[x] ^ cr[x - d])) : uint8_t(kSgmOutsideCost);
}

// Adds a path's costs at one pixel into its sum: sum = base + L where the pass writes the sum first
// (base: the other direction's costs along the row), sum += L after; nothing without a sum.
inline void add_path(const int16_t* L, uint16_t* sum, const int16_t* base, int D) {
  if (!sum) return;
  if (base)
    for (int d = 0; d < D; ++d) sum[d] = uint16_t(base[d] + L[d]);
  else
    for (int d = 0; d < D; ++d) sum[d] = uint16_t(sum[d] + L[d]);
}

// One step of a path: next[d] = cost[d] + min(prev[d], prev[d -+ 1] + p1, min(prev) + p2) - min(prev),
// then add_path. Values stay below 2^15 (costs <= 64, penalties <= 1000), so 16-bit lanes do.
CHUNGS_SGM_CLONES void path_step(const uint8_t* cost, const int16_t* prev, int16_t* next, uint16_t* sum,
                                 const int16_t* base, int D, int16_t p1, int16_t p2) {
  int16_t m = prev[0];
  for (int d = 1; d < D; ++d) m = std::min(m, prev[d]);
  const int16_t far = int16_t(m + p2);
  auto at = [&](int d, int16_t near) { next[d] = int16_t(cost[d] + std::min(std::min(prev[d], far), near) - m); };
  if (D == 1) {
    at(0, far);
  } else {
    at(0, int16_t(prev[1] + p1));
    for (int d = 1; d + 1 < D; ++d)
      next[d] = int16_t(cost[d] + std::min(std::min(prev[d], far), int16_t(std::min(prev[d - 1], prev[d + 1]) + p1)) - m);
    at(D - 1, int16_t(prev[D - 2] + p1));
  }
  add_path(next, sum, base, D);
}

CHUNGS_SGM_CLONES void path_start(const uint8_t* cost, int16_t* next, uint16_t* sum, const int16_t* base, int D) {
  for (int d = 0; d < D; ++d) next[d] = cost[d];
  add_path(next, sum, base, D);
}

// The lowest-cost disparity (lowest d on ties) if it beats every candidate outside +-1 by the
// uniqueness margin, refined by the parabola through its neighbours.
CHUNGS_SGM_CLONES void left_winner(const uint16_t* s, int D, int uniqueness, int16_t* out) {
  uint16_t m = s[0];
  for (int d = 1; d < D; ++d) m = std::min(m, s[d]);
  int best = 0;
  while (s[best] != m) ++best;
  int other = 1 << 30;
  for (int d = 0; d < best - 1; ++d) other = std::min<int>(other, s[d]);
  for (int d = best + 2; d < D; ++d) other = std::min<int>(other, s[d]);
  if (int64_t(other) * 100 <= int64_t(m) * (100 + uniqueness)) return;
  int v = best * 16;
  if (best > 0 && best + 1 < D) v += sgm_subpixel_offset(s[best - 1], m, s[best + 1]);
  *out = int16_t(v);
}

}  // namespace

SgmDisparities sgm_disparities(const Image8& left, const Image8& right, const SgmParams& params) {
  check_sgm_inputs(left, right, params);
  const int w = left.width(), h = left.height(), D = params.disparities;
  const int16_t p1 = int16_t(params.p1), p2 = int16_t(params.p2);
  const size_t px = size_t(w) * size_t(h);
  const std::vector<uint64_t> cl = census_9x7(left), cr = census_9x7(right);
  auto at = [&](int x, int y) { return (size_t(y) * w + x) * D; };
  SgmScratch& scratch = sgm_scratch();
  // Every element of both is written before it is read (census_costs: every pixel and disparity; the
  // sums: the first pass below), so old contents do not matter.
  scratch.cost.resize(std::max(scratch.cost.size(), px * D));
  scratch.sum.resize(std::max(scratch.sum.size(), px * D));
  uint8_t* const cost = scratch.cost.data();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) census_costs(&cl[size_t(y) * w], &cr[size_t(y) * w], w, D, &cost[at(0, y)]);
  // Sum over the four directions. Rows (left-right paths) are independent, and so are columns
  // (up-down paths, walked row by row over a band of columns so memory is read in order): each
  // pass splits them between threads without sharing a sum.
  uint16_t* const sum = scratch.sum.data();
#pragma omp parallel
  {
    // Left to right into a row of costs kept in cache; right to left then writes each sum once.
    std::vector<int16_t> row(size_t(w) * D), a(D), b(D);
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      path_start(&cost[at(0, y)], row.data(), nullptr, nullptr, D);
      for (int x = 1; x < w; ++x)
        path_step(&cost[at(x, y)], &row[size_t(x - 1) * D], &row[size_t(x) * D], nullptr, nullptr, D, p1, p2);
      path_start(&cost[at(w - 1, y)], a.data(), &sum[at(w - 1, y)], &row[size_t(w - 1) * D], D);
      for (int x = w - 2; x >= 0; --x) {
        path_step(&cost[at(x, y)], a.data(), b.data(), &sum[at(x, y)], &row[size_t(x) * D], D, p1, p2);
        std::swap(a, b);
      }
    }
    constexpr int kBand = 16;
    std::vector<int16_t> la(size_t(kBand) * D), lb(size_t(kBand) * D);
#pragma omp for schedule(static)
    for (int x0 = 0; x0 < w; x0 += kBand) {
      const int n = std::min(kBand, w - x0);
      for (int dir : {1, -1}) {
        const int y0 = dir > 0 ? 0 : h - 1;
        for (int i = 0; i < n; ++i)
          path_start(&cost[at(x0 + i, y0)], &la[size_t(i) * D], &sum[at(x0 + i, y0)], nullptr, D);
        for (int y = y0 + dir; y >= 0 && y < h; y += dir) {
          for (int i = 0; i < n; ++i)
            path_step(&cost[at(x0 + i, y)], &la[size_t(i) * D], &lb[size_t(i) * D], &sum[at(x0 + i, y)], nullptr, D,
                      p1, p2);
          std::swap(la, lb);
        }
      }
    }
  }
  SgmDisparities out;
  out.width = w, out.height = h;
  out.left.assign(px, kNoDisparity);
  out.right.assign(px, kNoDisparity);
#pragma omp parallel
  {
    std::vector<int> right_cost(w);
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      std::fill(right_cost.begin(), right_cost.end(), 1 << 30);
      int16_t* rd = &out.right[size_t(y) * w];
      for (int x = 0; x < w; ++x) {
        const uint16_t* s = &sum[at(x, y)];
        left_winner(s, D, params.uniqueness, &out.left[size_t(y) * w + x]);
        // Right pixel x - d sees this pixel at disparity d; x rises, so the first (lowest) d of a
        // tie stays.
        for (int d = 0, n = std::min(D, x + 1); d < n; ++d)
          if (s[d] < right_cost[x - d]) right_cost[x - d] = s[d], rd[x - d] = int16_t(d * 16);
      }
    }
  }
  return out;
}

}  // namespace chungs
