// Semi-global matching: the optimised CPU code against a direct transcription of its definition
// (census, four path recursions, winners) on random images, bit for bit; the sub-pixel rounding
// against floating point; parameter checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <bitset>
#include <cmath>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/depth/sgm.hpp"

namespace chungs {
namespace {

Image8 noise(int w, int h, std::mt19937& rng) {
  Image8 out(w, h, 1);
  std::uniform_int_distribution<int> U(0, 255);
  for (auto& v : out.vec()) v = uint8_t(U(rng));
  return out;
}

// A textured pair whose right image is the left one shifted by `d` with noise added, so that the
// costs have real minima and ties are rare but possible.
std::pair<Image8, Image8> pair_of(int w, int h, int d, std::mt19937& rng) {
  const Image8 l = noise(w, h, rng);
  Image8 r(w, h, 1);
  std::uniform_int_distribution<int> n(-6, 6);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) r(x, y) = uint8_t(std::clamp(int(l(std::min(w - 1, x + d), y)) + n(rng), 0, 255));
  return {l, r};
}

// The definition, written plainly: L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d+-1) + P1,
// min_k L_r(p-r, k) + P2) - min_k L_r(p-r, k), summed over r in {left, right, up, down}.
SgmDisparities reference(const Image8& l, const Image8& r, const SgmParams& p) {
  const int w = l.width(), h = l.height(), D = p.disparities;
  auto census = [&](const Image8& g, int x, int y) {
    uint64_t bits = 0;
    for (int dy = -3; dy <= 3; ++dy)
      for (int dx = -4; dx <= 4; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const int xx = x + dx, yy = y + dy;
        const bool in = xx >= 0 && xx < w && yy >= 0 && yy < h;
        bits = bits * 2 + (in && g(xx, yy) < g(x, y) ? 1 : 0);
      }
    return bits;
  };
  auto C = [&](int x, int y, int d) {
    if (x < d) return kSgmOutsideCost;
    return int(std::bitset<64>(census(l, x, y) ^ census(r, x - d, y)).count());
  };
  std::vector<long> S(size_t(w) * h * D, 0);
  const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (const auto& dir : dirs) {
    std::vector<long> L(size_t(w) * h * D);
    auto idx = [&](int x, int y, int d) { return (size_t(y) * w + x) * D + d; };
    // Visit pixels in the path's order: a pixel's predecessor is (x - dx, y - dy).
    for (int i = 0; i < w * h; ++i) {
      const int y = dir[1] < 0 ? h - 1 - i / w : i / w;
      const int x = dir[0] < 0 ? w - 1 - i % w : i % w;
      const int px = x - dir[0], py = y - dir[1];
      const bool start = px < 0 || px >= w || py < 0 || py >= h;
      long m = 1L << 40;
      if (!start)
        for (int k = 0; k < D; ++k) m = std::min(m, L[idx(px, py, k)]);
      for (int d = 0; d < D; ++d) {
        long v = C(x, y, d);
        if (!start) {
          long best = std::min(L[idx(px, py, d)], m + p.p2);
          if (d > 0) best = std::min(best, L[idx(px, py, d - 1)] + p.p1);
          if (d + 1 < D) best = std::min(best, L[idx(px, py, d + 1)] + p.p1);
          v += best - m;
        }
        L[idx(x, y, d)] = v;
        S[idx(x, y, d)] += v;
      }
    }
  }
  SgmDisparities out;
  out.width = w, out.height = h;
  out.left.assign(size_t(w) * h, kNoDisparity);
  out.right.assign(size_t(w) * h, kNoDisparity);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const long* s = &S[(size_t(y) * w + x) * D];
      const int best = int(std::min_element(s, s + D) - s);
      bool unique = true;
      for (int d = 0; d < D; ++d)
        if (std::abs(d - best) > 1 && s[d] * 100 <= s[best] * (100 + p.uniqueness)) unique = false;
      if (unique) {
        int v = best * 16;
        if (best > 0 && best + 1 < D) v += sgm_subpixel_offset(int(s[best - 1]), int(s[best]), int(s[best + 1]));
        out.left[size_t(y) * w + x] = int16_t(v);
      }
      int rb = 0;
      for (int d = 1; d < D && x + d < w; ++d)
        if (S[(size_t(y) * w + x + d) * D + d] < S[(size_t(y) * w + x + rb) * D + rb]) rb = d;
      out.right[size_t(y) * w + x] = int16_t(rb * 16);
    }
  return out;
}

TEST(Sgm, MatchesItsDefinitionBitForBit) {
  std::mt19937 rng(21);
  struct Case { int w, h, d, D, p1, p2, uniq; };
  for (const Case c : {Case{37, 19, 5, 16, 10, 120, 10}, Case{50, 23, 9, 33, 7, 80, 0}, Case{24, 9, 2, 3, 10, 120, 15},
                       Case{41, 12, 30, 64, 3, 300, 5}}) {
    const auto [l, r] = pair_of(c.w, c.h, c.d, rng);
    SgmParams p;
    p.disparities = c.D, p.p1 = c.p1, p.p2 = c.p2, p.uniqueness = c.uniq;
    const SgmDisparities got = sgm_disparities(l, r, p), want = reference(l, r, p);
    EXPECT_EQ(got.left, want.left) << c.w << "x" << c.h << " D " << c.D;
    EXPECT_EQ(got.right, want.right) << c.w << "x" << c.h << " D " << c.D;
    size_t matched = 0;
    for (int16_t v : got.left) matched += v != kNoDisparity;
    EXPECT_GT(matched, 0u);  // the case exercises winners, not only rejections
  }
}

TEST(Sgm, FindsTheShiftOfATexturedPair) {
  std::mt19937 rng(3);
  const auto [l, r] = pair_of(120, 40, 11, rng);
  SgmParams p;
  p.disparities = 32;
  const SgmDisparities s = sgm_disparities(l, r, p);
  size_t right = 0, total = 0;
  for (int y = 0; y < 40; ++y)
    for (int x = 40; x < 110; ++x, ++total) right += std::abs(s.left[size_t(y) * 120 + x] - 11 * 16) <= 8;
  EXPECT_GT(right, total * 9 / 10);
}

TEST(Sgm, SubpixelOffsetIsTheRoundedParabolaVertex) {
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> U(0, 3000);
  for (int i = 0; i < 20000; ++i) {
    const int b = U(rng), a = b + U(rng) % 400, c = b + U(rng) % 400;
    const int den = std::max(a + c - 2 * b, 1);
    const double exact = 16.0 * (a - c) / (2.0 * den);
    const int got = sgm_subpixel_offset(a, b, c);
    EXPECT_EQ(got, int(std::floor(exact + 0.5))) << a << " " << b << " " << c;
    EXPECT_LE(std::abs(got), 8);
  }
}

TEST(Sgm, RefusesBadInput) {
  SgmParams p;
  EXPECT_THROW(sgm_disparities(Image8(10, 5, 1), Image8(11, 5, 1), p), Error);
  EXPECT_THROW(sgm_disparities(Image8(10, 5, 3), Image8(10, 5, 3), p), Error);
  EXPECT_THROW(sgm_disparities(Image8(), Image8(), p), Error);
  p.disparities = 0;
  EXPECT_THROW(p.validate(), Error);
  p.disparities = 300;
  EXPECT_THROW(p.validate(), Error);
  p = {};
  p.p2 = 5;  // below p1
  EXPECT_THROW(p.validate(), Error);
  p = {};
  p.uniqueness = -1;
  EXPECT_THROW(p.validate(), Error);
}

}  // namespace
}  // namespace chungs
