// Half-precision chunk files: binary16 conversion against a float64 reference, and chunk files
// whose Adam moments and/or SH rest coefficients are stored at half size.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <tuple>

#include "chungs/common/error.hpp"
#include "chungs/store/atomic_file.hpp"
#include "chungs/store/checksum.hpp"
#include "chungs/store/chunk_codec.hpp"
#include "chungs/store/chunk_file.hpp"
#include "chungs/store/chunk_store.hpp"
#include "chungs/store/half_float.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;
namespace fs = std::filesystem;

namespace {
const ChunkId kId = chunk_id({-7, 3, 1});

// The binary16 value of bits h, in float64, by the definition of the format.
double half_value(uint16_t h) {
  const int e = (h >> 10) & 0x1f, m = h & 0x3ff;
  const double mag = e == 0 ? std::ldexp(double(m), -24) : std::ldexp(1.0 + m / 1024.0, e - 15);
  return (h & 0x8000) ? -mag : mag;
}

// A block as the optimiser leaves it: Adam's second moment is never negative.
GaussianBlock trained_block(size_t n, uint64_t seed) {
  GaussianBlock b = test::random_block(n, seed);
  for (auto* v : {&b.adam_v.mean, &b.adam_v.log_scale, &b.adam_v.rotation, &b.adam_v.opacity, &b.adam_v.sh})
    for (float& x : *v) x = x * x * 1e3f;  // ~1e-9 .. 1e-14, a wide spread like squared gradients
  return b;
}

void expect_close(const std::vector<float>& got, const std::vector<float>& want, double rel, double floor,
                  const char* what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (size_t i = 0; i < got.size(); ++i)
    ASSERT_LE(std::abs(double(got[i]) - want[i]), rel * std::abs(double(want[i])) + floor)
        << what << "[" << i << "]: " << got[i] << " vs " << want[i];
}
double largest(const std::vector<float>& v) {
  double m = 0;
  for (float x : v) m = std::max(m, std::abs(double(x)));
  return m;
}
}  // namespace

TEST(HalfFloat, EveryHalfRoundTripsThroughFloat) {
  for (uint32_t h = 0; h < 0x10000; ++h) {
    const float f = half_to_float(uint16_t(h));
    if (std::isnan(f)) {
      EXPECT_TRUE(((h >> 10) & 0x1f) == 0x1f && (h & 0x3ff)) << h;
      EXPECT_TRUE(std::isnan(half_to_float(float_to_half(f))));
      continue;
    }
    if (((h >> 10) & 0x1f) != 0x1f) {
      ASSERT_EQ(double(f), half_value(uint16_t(h))) << h;
    }
    ASSERT_EQ(float_to_half(f), h) << h;
  }
}

TEST(HalfFloat, RoundsRandomFloatsToTheNearestHalfTiesToEven) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> exponent(-30, 17);
  std::uniform_real_distribution<double> mantissa(1.0, 2.0);
  for (int i = 0; i < 200000; ++i) {
    float f = float(std::ldexp(mantissa(rng), exponent(rng)));
    if (i % 2) f = -f;
    if (i % 1000 == 0) f = std::ldexp(float(1 + 2 * (rng() % 1024)), -25 + int(rng() % 30));  // exact ties
    const uint16_t h = float_to_half(f);
    const double x = f;
    if (std::abs(x) >= 65520.0) {
      ASSERT_EQ(h & 0x7fff, 0x7c00) << f;
      continue;
    }
    // Reference: the two float64 neighbours of x among all finite halves of its sign.
    const double got = half_value(h);
    for (int d : {-1, 1}) {
      const uint16_t other = uint16_t(h + d);
      if ((other & 0x7fff) >= 0x7c00 || ((other ^ h) & 0x8000)) continue;
      const double alt = half_value(other);
      const double e_got = std::abs(got - x), e_alt = std::abs(alt - x);
      ASSERT_TRUE(e_got < e_alt || (e_got == e_alt && (h & 1) == 0))
          << f << " -> " << got << " but " << alt << " is as near or nearer";
    }
  }
  EXPECT_EQ(float_to_half(std::numeric_limits<float>::infinity()), 0x7c00);
  EXPECT_EQ(float_to_half(-0.0f), 0x8000);
  EXPECT_EQ(float_to_half(1e-9f), 0u);  // below half the smallest subnormal
}

TEST(HalfFloat, ArrayConversionsEqualTheScalarOnes) {
  std::mt19937 rng(11);
  std::vector<float> in(100003);  // not a multiple of the vector width
  for (float& f : in) {
    const uint32_t bits = rng();
    std::memcpy(&f, &bits, 4);  // every exponent: subnormals, overflow, infinities, NaN
  }
  std::vector<uint16_t> h(in.size());
  floats_to_halves(in.data(), h.data(), in.size());
  for (size_t i = 0; i < in.size(); ++i) {
    if (std::isnan(in[i])) {
      ASSERT_TRUE((h[i] & 0x7c00) == 0x7c00 && (h[i] & 0x3ff)) << i;
      continue;
    }
    ASSERT_EQ(h[i], float_to_half(in[i])) << in[i];
  }
  std::vector<uint16_t> all(0x10000);
  for (uint32_t k = 0; k < all.size(); ++k) all[k] = uint16_t(k);
  std::vector<float> back(all.size());
  halves_to_floats(all.data(), back.data(), all.size());
  for (uint32_t k = 0; k < all.size(); ++k) {
    const float want = half_to_float(uint16_t(k));
    if (std::isnan(want)) {
      ASSERT_TRUE(std::isnan(back[k])) << k;
    } else {
      ASSERT_EQ(std::memcmp(&back[k], &want, 4), 0) << k;
    }
  }
}

TEST(HalfFloat, FusedArrayHelpersEqualTheirScalarDefinitions) {
  std::mt19937 rng(12);
  std::normal_distribution<float> g(0.f, 1.f);
  const size_t n = 1003;
  std::vector<float> in(n);
  for (size_t i = 0; i < n; ++i) in[i] = std::ldexp(g(rng), int(rng() % 60) - 40);
  in[5] = 0.0f, in[6] = -0.0f, in[7] = std::numeric_limits<float>::infinity(), in[8] = std::nanf("");
  in[900] = -1e30f;  // the largest magnitude, in the scalar tail of no block
  EXPECT_EQ(max_finite_abs(in.data(), n), 1e30f);
  std::vector<float> roots(n);
  signed_sqrt(in.data(), roots.data(), n);
  for (size_t i = 0; i < n; ++i) {
    const float want = std::copysign(std::sqrt(std::fabs(in[i])), in[i]);
    if (std::isnan(want)) {
      EXPECT_TRUE(std::isnan(roots[i]));
    } else {
      ASSERT_EQ(std::memcmp(&roots[i], &want, 4), 0) << i;
    }
  }
  const float factor = std::ldexp(1.0f, 7);
  std::vector<uint8_t> bytes(2 * n + 2);  // at an odd 2-byte offset, as in a chunk payload
  scaled_floats_to_halves(in.data(), factor, bytes.data() + 2, n);
  std::vector<float> back(n);
  halves_to_scaled_floats(bytes.data() + 2, 1 / factor, back.data(), n);
  for (size_t i = 0; i < n; ++i) {
    uint16_t h;
    std::memcpy(&h, bytes.data() + 2 + 2 * i, 2);
    if (std::isnan(in[i])) continue;
    ASSERT_EQ(h, float_to_half(in[i] * factor)) << i;
    const float want = half_to_float(h) / factor;
    ASSERT_EQ(std::memcmp(&back[i], &want, 4), 0) << i;
  }
  keep_nonzero(in.data(), bytes.data() + 2, n);
  for (size_t i = 0; i < n; ++i) {
    uint16_t h;
    std::memcpy(&h, bytes.data() + 2 + 2 * i, 2);
    EXPECT_EQ((h & 0x7fff) == 0, in[i] == 0) << i << ": " << in[i];
  }
}

TEST(ChunkFileHalf, ShrinksFilesAsAnnouncedAndKeepsParametersExact) {
  test::TempDir dir;
  const GaussianBlock b = trained_block(300, 1);
  const uint64_t n = b.size();
  struct Case {
    bool m, sh;
    uint64_t per_gaussian;
  };
  for (const Case c :
       {Case{false, false, 724}, Case{true, false, 488}, Case{true, true, 398}, Case{false, true, 634}}) {
    const fs::path f = dir / "c.chunk";
    const auto info = write_chunk_file(f, kId, b, {false, 1, true, false, c.m, c.sh});
    const uint64_t constant = (c.m ? 40 : 0) + (c.sh ? 4 : 0);  // one scale per half array
    EXPECT_EQ(info.file_bytes, 72 + n * c.per_gaussian + constant) << c.m << c.sh;
    EXPECT_EQ(chunk_payload_bytes(n, info.flags), n * c.per_gaussian + constant);
    for (bool compress : {false, true}) {
      write_chunk_file(f, kId, b, {compress, 1, true, false, c.m, c.sh});
      GaussianBlock r;
      read_chunk_file(f, r);
      // Bit-exact where not halved.
      EXPECT_EQ(r.params.mean, b.params.mean);
      EXPECT_EQ(r.params.rotation, b.params.rotation);
      EXPECT_EQ(r.params.opacity, b.params.opacity);
      EXPECT_EQ(r.adam_steps, b.adam_steps);
      EXPECT_EQ(r.created_at_step, b.created_at_step);
      EXPECT_EQ(r.lr_position_factor, b.lr_position_factor);
      for (size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) ASSERT_EQ(r.params.sh[48 * i + k], b.params.sh[48 * i + k]);  // DC
      if (!c.sh) {
        EXPECT_EQ(r.params.sh, b.params.sh);
      }
      if (!c.m) {
        EXPECT_TRUE(r.adam_m.mean == b.adam_m.mean && r.adam_v.sh == b.adam_v.sh);
      }
    }
  }
}

// Uncompressed files are encoded and decoded a piece of 2,048 Gaussians at a time, zstd ones an array
// at a time: both, on blocks of one piece and of two (the last one partial), with each array's
// largest value in the last piece, where a scale taken from the first piece alone would not reach.
class ChunkFileHalfSizes : public ::testing::TestWithParam<std::tuple<size_t, bool>> {};
INSTANTIATE_TEST_SUITE_P(PiecesAndZstd, ChunkFileHalfSizes,
                         ::testing::Combine(::testing::Values(size_t(500), size_t(2500)), ::testing::Bool()));

TEST_P(ChunkFileHalfSizes, MomentsAndShComeBackWithinHalfPrecision) {
  const auto [n, compress] = GetParam();
  test::TempDir dir;
  GaussianBlock b = trained_block(n, 2);
  b.adam_v.opacity[7] = 1e-36f;  // sqrt 1e-18, far below what the array's scale resolves
  for (auto* v : {&b.params.sh, &b.adam_m.sh, &b.adam_m.mean, &b.adam_v.sh, &b.adam_v.rotation}) {
    const float top = float(largest(*v));
    v->back() = (v == &b.adam_m.mean ? -50.f : 50.f) * top;
  }
  b.params.sh[48 * (n - 1) + 1] = 1e6f;  // a DC value, kept as float32 and out of the rest's scale
  const fs::path f = dir / "h.chunk";
  write_chunk_file(f, kId, b, {compress, 1, true, false, true, true});
  GaussianBlock r;
  read_chunk_file(f, r);
  EXPECT_EQ(r.params.sh[48 * (n - 1) + 1], 1e6f);
  const double rel = std::ldexp(1.0, -11);  // half's rounding, with margin for the scale
  // SH rest: relative precision unless far below the array's largest value.
  expect_close(r.params.sh, b.params.sh, rel, largest(b.params.sh) * std::ldexp(1.0, -40), "sh");
  for (auto [got, want] : {std::pair{&r.adam_m, &b.adam_m}, std::pair{&r.adam_v, &b.adam_v}}) {
    const bool second = want == &b.adam_v;
    for (auto arr : {&GaussianParams::mean, &GaussianParams::log_scale, &GaussianParams::rotation,
                     &GaussianParams::opacity, &GaussianParams::sh}) {
      const auto& w = want->*arr;
      const auto& g = got->*arr;
      // v is stored as sqrt(v): relative error doubles, and the range is twice as wide in log.
      expect_close(g, w, second ? 2.2 * rel : rel,
                   largest(w) * (second ? std::ldexp(1.0, -70) : std::ldexp(1.0, -40)),
                   second ? "adam_v" : "adam_m");
      if (second) {
        for (size_t i = 0; i < w.size(); ++i)
          ASSERT_TRUE(w[i] == 0 || g[i] > 0) << "a non-zero second moment decoded to zero at " << i;
      }
    }
  }
}

TEST(ChunkFileHalf, ReadsVersion1FilesAndNamesTheFileForUnknownVersions) {
  test::TempDir dir;
  const fs::path f = dir / "v1.chunk";
  const GaussianBlock b = test::random_block(20, 3);
  write_chunk_file(f, kId, b, {false, 1, false, false});
  // Make it a version 1 file as the previous build wrote it: same layout, version 1.
  auto bytes = read_whole_file(f);
  auto set_version = [&](uint32_t v) {
    std::memcpy(bytes.data() + 8, &v, 4);
    const uint64_t sum = xxh64(bytes.data(), 64);
    std::memcpy(bytes.data() + 64, &sum, 8);
    std::ofstream(f, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  };
  set_version(1);
  GaussianBlock r;
  read_chunk_file(f, r);
  EXPECT_TRUE(test::same_bits(r, b));
  set_version(3);
  try {
    read_chunk_file(f, r);
    FAIL();
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(f.string()), std::string::npos) << what;
    EXPECT_NE(what.find("version 3"), std::string::npos) << what;
  }
  // A version 1 header cannot carry the half flags (they did not exist).
  write_chunk_file(f, kId, b, {false, 1, false, false, true, false});
  bytes = read_whole_file(f);
  set_version(1);
  EXPECT_THROW(read_chunk_file(f, r), Error);
}

TEST(ChunkFileHalf, StoreWritesHalfFilesWhenAskedAndReadsThemWithTheSettingOff) {
  test::TempDir dir;
  const ChunkId id = chunk_id({1, 1, 1});
  const GaussianBlock b = trained_block(100, 4);
  uint64_t half_bytes = 0;
  {
    ChunkStoreConfig c;
    c.durable = false;
    c.half_moments = c.half_sh_rest = true;
    ChunkStore s(dir.path(), c);
    s.save(id, b);
    half_bytes = fs::file_size(s.chunk_path(id));
  }
  EXPECT_EQ(half_bytes, 72 + 100 * 398 + 44);
  ChunkStoreConfig c;
  c.durable = false;
  c.verify_on_open = true;
  c.half_moments = c.half_sh_rest = false;
  ChunkStore s(dir.path(), c);
  const GaussianBlock r = s.load(id);
  EXPECT_EQ(r.params.mean, b.params.mean);
  expect_close(r.adam_m.mean, b.adam_m.mean, std::ldexp(1.0, -11), 0, "adam_m");
  s.save(id, r);
  EXPECT_EQ(fs::file_size(s.chunk_path(id)), 72 + 100 * kChunkBytesPerGaussian);
}
