// The 3DGS PLY layout: header, 62 float32 per Gaussian, f_rest channel-major.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "chungs/pipeline/ply_export.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

TEST(PlyExport, WritesStandardLayoutWithChannelMajorRest) {
  test::TempDir dir;
  GaussianBlock b;
  b.resize(3);
  std::mt19937 rng(1);
  std::normal_distribution<float> N(0, 1);
  for (auto* v : {&b.params.mean, &b.params.log_scale, &b.params.rotation, &b.params.opacity, &b.params.sh})
    for (auto& x : *v) x = N(rng);
  write_gaussian_ply(dir / "a.ply", {&b});
  std::ifstream in(dir / "a.ply", std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string all = ss.str();
  const size_t end = all.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  const std::string head = all.substr(0, end);
  EXPECT_NE(head.find("element vertex 3\n"), std::string::npos);
  EXPECT_NE(head.find("property float f_rest_44\n"), std::string::npos);
  EXPECT_LT(head.find("property float opacity"), head.find("property float scale_0"));
  const char* body = all.data() + end + 11;
  ASSERT_EQ(all.size() - (end + 11), 3u * 62u * 4u);
  for (size_t i = 0; i < 3; ++i) {
    float row[62];
    std::memcpy(row, body + i * 62 * 4, sizeof row);
    EXPECT_EQ(row[0], b.params.mean[3 * i]);
    EXPECT_EQ(row[6 + 1], b.params.sh[48 * i + 1]);  // f_dc_1: DC of green
    // f_rest_j: channel c = j / 15, coefficient k = 1 + j % 15.
    for (int j = 0; j < 45; ++j) EXPECT_EQ(row[9 + j], b.params.sh[48 * i + 3 * (1 + j % 15) + j / 15]) << j;
    EXPECT_EQ(row[54], b.params.opacity[i]);
    EXPECT_EQ(row[55 + 2], b.params.log_scale[3 * i + 2]);
    EXPECT_EQ(row[58], b.params.rotation[4 * i]);  // w first
  }
}

}  // namespace
}  // namespace chungs
