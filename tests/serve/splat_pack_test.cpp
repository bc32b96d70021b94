// The packed chunk layout the viewer hands to Spark: encodings checked against their decoders on
// random values, and every field of a packed chunk against the block it came from.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "chungs/common/error.hpp"
#include "chungs/render/sh.hpp"
#include "chungs/serve/splat_pack.hpp"
#include "chungs/store/half_float.hpp"
#include "store/random_block.hpp"

using namespace chungs;
using namespace chungs::serve;

namespace {

uint32_t word(const std::string& s, size_t offset) {
  uint32_t w;
  std::memcpy(&w, s.data() + offset, 4);
  return w;
}

float half_lo(uint32_t w) { return half_to_float(uint16_t(w & 0xffffu)); }
float half_hi(uint32_t w) { return half_to_float(uint16_t(w >> 16)); }

}  // namespace

TEST(SplatPack, RotationsSurviveTheOctahedralEncodingWithinHalfADegree) {
  std::mt19937 rng(7);
  std::normal_distribution<float> g;
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    const float q[4] = {g(rng), g(rng), g(rng), g(rng)};
    const double n = std::sqrt(double(q[0]) * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    float d[4];
    decode_rotation(encode_rotation(q[0], q[1], q[2], q[3]), d);
    const double dot = std::abs(q[0] * d[0] + q[1] * d[1] + q[2] * d[2] + q[3] * d[3]) / n;
    worst = std::max(worst, 2 * std::acos(std::min(1.0, dot)) * 180 / M_PI);
  }
  EXPECT_LT(worst, 0.5);
  EXPECT_GT(worst, 0.0);  // it is an encoding, not a copy
}

TEST(SplatPack, ShTriplesKeepTheirSignsAndLargestComponentToAPart) {
  std::mt19937 rng(3);
  std::normal_distribution<float> g;
  for (int i = 0; i < 20000; ++i) {
    const float scale = std::exp(2 * g(rng));  // within the exponent's range, 2^-15..2^16
    const float v[3] = {scale * g(rng), scale * g(rng), scale * g(rng)};
    float d[3];
    decode_sh_rgb(encode_sh_rgb(v[0], v[1], v[2]), d);
    const float m = std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
    for (int c = 0; c < 3; ++c) {
      // A step is 2^e / 255 with 2^e <= 2 m, so rounding is off by m / 255 at most.
      ASSERT_NEAR(d[c], v[c], m / 255 + 1e-7) << i << " " << c;
      if (std::abs(v[c]) > m / 100) {
        ASSERT_EQ(d[c] < 0, v[c] < 0);
      }
    }
  }
  float z[3];
  decode_sh_rgb(encode_sh_rgb(0, 0, 0), z);
  EXPECT_EQ(z[0], 0.f);
}

TEST(SplatPack, EveryFieldOfAPackedChunkMatchesItsGaussian) {
  const GaussianBlock b = test::random_block(37, 11, 12000.f, -3.f, 5000.f);  // 12 km out
  const double origin[3] = {12000, -3, 5000};
  const std::string s = pack_splats(b.params, 3, origin, 0x1234567890ull, 42);
  ASSERT_EQ(s.size(), splat_pack_bytes(37, 3));
  ASSERT_EQ(s.size(), 64 + 6 * 16 * 37u);
  EXPECT_EQ(s.substr(0, 8), "DCSPLAT1");
  EXPECT_EQ(word(s, 8), kSplatPackVersion);
  EXPECT_EQ(word(s, 12), 37u);
  EXPECT_EQ(word(s, 16), 3u);
  EXPECT_EQ(word(s, 20), 64u);
  double o[3];
  std::memcpy(o, s.data() + 24, sizeof o);
  EXPECT_EQ(o[1], -3.0);
  uint64_t id, gen;
  std::memcpy(&id, s.data() + 48, 8);
  std::memcpy(&gen, s.data() + 56, 8);
  EXPECT_EQ(id, 0x1234567890ull);
  EXPECT_EQ(gen, 42u);

  const size_t n = 37, A = 64, B = A + 16 * n, S1 = B + 16 * n, S2 = S1 + 16 * n, S3a = S2 + 16 * n, S3b = S3a + 16 * n;
  for (size_t i = 0; i < n; ++i) {
    const auto& p = b.params;
    for (int k = 0; k < 3; ++k) {
      float rel;
      std::memcpy(&rel, s.data() + A + 16 * i + 4 * k, 4);
      // Relative to the origin: well under a millimetre, where world float32 would be 1 mm steps.
      EXPECT_NEAR(double(rel) + origin[k], p.mean[3 * i + k], 1e-4);
    }
    const float opacity = 1 / (1 + std::exp(-p.opacity[i]));
    EXPECT_NEAR(half_lo(word(s, A + 16 * i + 12)), opacity, 1e-3);
    const float* sh = &p.sh[size_t(kShFloats) * i];
    EXPECT_NEAR(half_lo(word(s, B + 16 * i)), 0.5 + sh::kC0 * sh[0], 2e-3);
    EXPECT_NEAR(half_hi(word(s, B + 16 * i)), 0.5 + sh::kC0 * sh[1], 2e-3);
    EXPECT_NEAR(half_lo(word(s, B + 16 * i + 4)), 0.5 + sh::kC0 * sh[2], 2e-3);
    EXPECT_NEAR(half_hi(word(s, B + 16 * i + 4)), p.log_scale[3 * i], 5e-3);
    EXPECT_NEAR(half_lo(word(s, B + 16 * i + 8)), p.log_scale[3 * i + 1], 5e-3);
    EXPECT_NEAR(half_hi(word(s, B + 16 * i + 8)), p.log_scale[3 * i + 2], 5e-3);
    float q[4];
    decode_rotation(word(s, B + 16 * i + 12), q);
    const float* r = &p.rotation[4 * i];
    const float rn = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    EXPECT_NEAR(std::abs(q[0] * r[0] + q[1] * r[1] + q[2] * r[2] + q[3] * r[3]) / rn, 1.0, 1e-4);
    // SH coefficient k in the array and word Spark reads it from.
    auto coeff_at = [&](size_t base, int w) {
      float d[3];
      decode_sh_rgb(word(s, base + 16 * i + 4 * size_t(w)), d);
      return std::array<float, 3>{d[0], d[1], d[2]};
    };
    const std::pair<size_t, int> where[16] = {{0, 0},      {S1, 0},     {S1, 1},     {S1, 2},     {S1, 3},  {S2, 0},
                                              {S2, 1},     {S2, 2},     {S2, 3},     {S3a, 0},    {S3a, 1}, {S3a, 2},
                                              {S3a, 3},    {S3b, 0},    {S3b, 1},    {S3b, 2}};
    for (int k = 1; k < 16; ++k) {
      const auto d = coeff_at(where[k].first, where[k].second);
      const float m = std::max({std::abs(sh[3 * k]), std::abs(sh[3 * k + 1]), std::abs(sh[3 * k + 2])});
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(d[c], sh[3 * k + c], m / 255 + 1e-9) << "coefficient " << k;
    }
    EXPECT_EQ(word(s, S3b + 16 * i + 12), 0u);
  }
}

TEST(SplatPack, LowerDegreesCarryFewerArraysAndDegreeFourIsRefused) {
  const GaussianBlock b = test::random_block(5, 2);
  const double origin[3] = {0, 0, 0};
  for (int d = 0; d <= 3; ++d) {
    const std::string s = pack_splats(b.params, d, origin, 1, 1);
    EXPECT_EQ(s.size(), splat_pack_bytes(5, d));
    EXPECT_EQ(word(s, 16), uint32_t(d));
  }
  EXPECT_EQ(splat_pack_bytes(5, 0), 64 + 2 * 16 * 5u);
  EXPECT_EQ(splat_pack_bytes(5, 1), 64 + 3 * 16 * 5u);
  // At degree 1 the fourth sh1 word (degree 2's first coefficient) stays empty.
  EXPECT_EQ(word(pack_splats(b.params, 1, origin, 1, 1), 64 + 2 * 16 * 5 + 12), 0u);
  EXPECT_THROW(pack_splats(b.params, 4, origin, 1, 1), Error);
  EXPECT_THROW(pack_splats(b.params, -1, origin, 1, 1), Error);
}
