// The sky in the mapper: trained by steps where the Gaussians leave the image clear, drawn by the
// mapper's and a reader's renders, committed with checkpoints (sky.bin) and resumed; the file's
// reader refuses damaged or mislabelled files before allocating.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "chungs/mapping/mapper.hpp"
#include "chungs/pipeline/render_poses.hpp"
#include "chungs/mapping/sky_file.hpp"
#include "test_support.hpp"
#include "mapping/tiny_config.hpp"

namespace chungs {
namespace {

namespace fs = std::filesystem;

SkyTexture random_sky(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(0, 1);
  const double R[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};  // camera y down = world -z: up is +z
  SkyConfig cfg;
  cfg.width = 12;
  cfg.height = 6;
  SkyTexture s = make_sky(cfg, R);
  for (float& v : s.rgb) v = U(rng);
  for (float& v : s.m1) v = U(rng) - 0.5f;
  for (float& v : s.m2) v = U(rng);
  for (uint32_t& v : s.updates) v = uint32_t(rng() % 100);
  return s;
}

TEST(SkyFile, RoundTripsExactly) {
  test::TempDir dir;
  const SkyTexture s = random_sky(1);
  write_sky_file(dir.path() / "sky.bin", s, false);
  const SkyTexture r = read_sky_file(dir.path() / "sky.bin");
  EXPECT_EQ(r.width, s.width);
  EXPECT_EQ(r.height, s.height);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(r.axes[i], s.axes[i]);
  EXPECT_EQ(r.rgb, s.rgb);
  EXPECT_EQ(r.m1, s.m1);
  EXPECT_EQ(r.m2, s.m2);
  EXPECT_EQ(r.updates, s.updates);
}

void expect_refused(const fs::path& file, const std::string& words) {
  try {
    read_sky_file(file);
    FAIL() << "accepted " << file;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << what;
  }
}

TEST(SkyFile, DamagedFilesAreRefusedNamingTheFile) {
  test::TempDir dir;
  const fs::path f = dir.path() / "sky.bin";
  write_sky_file(f, random_sky(2), false);
  std::string bytes;
  {
    std::ifstream in(f, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto put = [&](const std::string& b) { std::ofstream(f, std::ios::binary | std::ios::trunc) << b; };
  put(bytes.substr(0, bytes.size() - 9));
  expect_refused(f, "truncated");
  std::string flipped = bytes;
  flipped[200] ^= 0x10;
  put(flipped);
  expect_refused(f, "checksum");
  std::string magic = bytes;
  magic[0] = 'X';
  put(magic);
  expect_refused(f, "magic");
  // A 60-byte file that declares 4096 x 2048 texels (~300 MB): refused by its length.
  std::string huge = bytes.substr(0, 60);
  const int32_t w = 4096, h = 2048;
  huge.replace(8, 4, reinterpret_cast<const char*>(&w), 4);
  huge.replace(12, 4, reinterpret_cast<const char*>(&h), 4);
  put(huge);
  expect_refused(f, "do not match");
  std::string big = bytes;
  const int32_t w2 = 100000;
  big.replace(8, 4, reinterpret_cast<const char*>(&w2), 4);
  put(big);
  expect_refused(f, "outside");
}

Config sky_config() {
  Config c = test::tiny_mapping_config();
  c.mapper.device = "cpu";
  c.sky.enabled = true;
  c.sky.width = 32;
  c.sky.height = 16;
  c.sky.lr = 0.05;
  return c;
}

double mean_error(const ImageF& rgb, const float colour[3]) {
  double e = 0;
  for (int v = 0; v < rgb.height(); ++v)
    for (int u = 0; u < rgb.width(); ++u)
      for (int c = 0; c < 3; ++c) e += std::abs(rgb(u, v, c) - colour[c]);
  return e / double(3 * rgb.pixels());
}

// A keyframe of plain sky (a colour, no depth anywhere): only the sky can explain it.
TEST(MapperSky, LearnsTheSkyAndKeepsItAcrossCheckpointsAndReaders) {
  test::TempDir dir;
  const fs::path map = dir.path() / "map";
  const float colour[3] = {0.2f, 0.45f, 0.8f};
  Image8 image(40, 30, 3);
  for (int v = 0; v < 30; ++v)
    for (int u = 0; u < 40; ++u)
      for (int c = 0; c < 3; ++c) image(u, v, c) = uint8_t(std::lround(colour[c] * 255));
  const ImageF no_depth(40, 30, 1);
  const Camera cam(40, 30, 30, 30, 19.5, 14.5);
  // Looking along world +y with the camera's y down = world -z.
  SE3 pose;
  pose.q = Eigen::Quaterniond(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()));
  pose.t = Eigen::Vector3d(1, 2, 0.5);
  {
    Mapper m(map, sky_config(), false);
    m.add_keyframe(0, 0.0, image, no_depth, cam, pose);
    EXPECT_GT(mean_error(m.render(cam, pose).rgb, colour), 0.4) << "a new sky is black";
    for (int i = 0; i < 80; ++i) m.step();
    EXPECT_LT(mean_error(m.render(cam, pose).rgb, colour), 0.02);
    m.checkpoint(nlohmann::json{{"next_frame", 1}});
  }
  ASSERT_TRUE(fs::exists(map / "sky.bin"));
  {
    MapRenderer reader(map, sky_config());
    EXPECT_LT(mean_error(reader.render(cam, pose).rgb, colour), 0.02);
  }
  {
    Mapper resumed(map, sky_config(), true);
    EXPECT_LT(mean_error(resumed.render(cam, pose).rgb, colour), 0.02);
  }
  // The sky's colour belongs to the texture, not to a fixed background: without it, black again.
  Config off = sky_config();
  off.sky.enabled = false;
  fs::remove(map / "sky.bin");
  MapRenderer without(map, off);
  EXPECT_GT(mean_error(without.render(cam, pose).rgb, colour), 0.4);
}

}  // namespace
}  // namespace chungs
