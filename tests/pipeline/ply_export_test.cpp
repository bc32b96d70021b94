// The 3DGS PLY layout: header, 62 float32 per Gaussian, f_rest channel-major.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "chungs/common/error.hpp"
#include "chungs/pipeline/ply_export.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

using test::read_all;

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


// A map export streams its rows (never the whole map in memory) and names the count in a header
// written last: every Gaussian of every chunk in order, a count that matches, whatever its digits.
TEST(PlyExport, AMapExportHoldsEveryGaussianUnderTheCountItsHeaderNames) {
  test::TempDir dir;
  ChunkStoreConfig c;
  c.half_moments = c.half_sh_rest = false;  // exact values to compare
  c.durable = false;
  uint64_t total = 0;
  std::vector<std::pair<ChunkId, GaussianBlock>> blocks;
  {
    ChunkStore store(dir / "map", c);
    for (int i = 0; i < 5; ++i) {
      blocks.emplace_back(chunk_id({i, 0, -i}), test::random_block(size_t(1000 + 997 * i), uint32_t(i + 1)));
      store.save(blocks.back().first, blocks.back().second);
      total += blocks.back().second.size();
    }
  }
  const ChunkStore store(dir / "map", reader_config(c));
  EXPECT_EQ(export_ply(store, dir / "all.ply", {}), total);
  const std::string all = read_all(dir / "all.ply");
  const size_t end = all.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(all.substr(0, end).find("\nelement vertex " + std::to_string(total) + "\n"), std::string::npos);
  ASSERT_EQ(all.size() - (end + 11), total * 62u * 4u);
  // Each chunk's rows follow the previous chunk's, in the store's order.
  size_t row = 0;
  for (ChunkId id : store.ids()) {
    float x;
    std::memcpy(&x, all.data() + end + 11 + row * 62 * 4, 4);
    EXPECT_EQ(x, store.load(id).params.mean[0]);
    row += store.count(id);
  }
  // One chunk: a count of fewer digits under a header of the same length (its padding comment is longer).
  const ChunkId first = store.ids().front();
  EXPECT_EQ(export_ply(store, dir / "one.ply", PlySelection{first, {}, {}}), store.count(first));
  const std::string one = read_all(dir / "one.ply");
  EXPECT_EQ(one.find("end_header\n"), end);
  EXPECT_EQ(one.size() - (end + 11), store.count(first) * 62u * 4u);
}

// A chunk that passed its checksum may still hold nan or inf: those Gaussians are left out and counted,
// never written as rows a viewer chokes on.
TEST(PlyExport, GaussiansWithNonFiniteValuesAreLeftOutAndCounted) {
  test::TempDir dir;
  ChunkStoreConfig c;
  c.durable = false;
  GaussianBlock b = test::random_block(100, 7);
  b.params.mean[3 * 5 + 1] = std::numeric_limits<float>::quiet_NaN();
  b.params.sh[48 * 9 + 20] = std::numeric_limits<float>::infinity();
  b.params.opacity[42] = -std::numeric_limits<float>::infinity();
  {
    ChunkStore store(dir / "map", c);
    store.save(chunk_id({1, 2, 3}), b);
  }
  const ChunkStore store(dir / "map", reader_config(c));
  testing::internal::CaptureStderr();
  EXPECT_EQ(export_ply(store, dir / "all.ply", {}), 97u);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("3 Gaussians hold nan or infinite values"), std::string::npos) << err;
  const std::string all = read_all(dir / "all.ply");
  const size_t body = all.find("end_header\n") + 11;
  ASSERT_EQ(all.size() - body, 97u * 62u * 4u);
  for (size_t k = body; k + 4 <= all.size(); k += 4) {
    float v;
    std::memcpy(&v, all.data() + k, 4);
    ASSERT_TRUE(std::isfinite(v)) << "float " << (k - body) / 4;
  }
}

// A PLY viewer draws every splat from wherever it looks: each cube goes in once, at its near level, or at
// its far level where the map saw it only from afar.
TEST(PlyExport, EachCubeGoesInOnceAtItsNearLevelOrItsOnlyOne) {
  test::TempDir dir;
  ChunkStoreConfig c;
  c.durable = false;
  const ChunkId both = chunk_id({0, 0, 1}), far_only = far_level_of(chunk_id({0, 0, 9}));
  {
    ChunkStore store(dir / "map", c);
    store.save(both, test::random_block(30, 1));
    store.save(far_level_of(both), test::random_block(7, 2));
    store.save(far_only, test::random_block(5, 3));
  }
  const ChunkStore store(dir / "map", reader_config(c));
  EXPECT_EQ(export_ply(store, dir / "all.ply", {}), 30u + 5u);
  // A cube named by its coordinates: its near level, or the far one when that is all there is.
  EXPECT_EQ(export_ply(store, dir / "one.ply", PlySelection{both, {}, {}}), 30u);
  EXPECT_EQ(export_ply(store, dir / "far.ply", PlySelection{near_level_of(far_only), {}, {}}), 5u);
  EXPECT_THROW(export_ply(store, dir / "none.ply", PlySelection{chunk_id({3, 3, 3}), {}, {}}), Error);
}

// An export that fails part way (here a damaged chunk) leaves the file that was there, never a partial
// one: it wrote the header with 0 Gaussians first, so a failed export left a valid, empty PLY.
TEST(PlyExport, AFailedExportLeavesTheFileThatWasThereAndNoTemporaries) {
  test::TempDir dir;
  ChunkStoreConfig c;
  c.durable = false;
  std::filesystem::path damaged;
  {
    ChunkStore store(dir / "map", c);
    for (int i = 0; i < 3; ++i) store.save(chunk_id({i, 0, 0}), test::random_block(300, uint32_t(i + 7)));
    damaged = store.chunk_path(chunk_id({2, 0, 0}));
  }
  std::filesystem::create_directories(dir / "out");
  const std::filesystem::path ply = dir / "out" / "map.ply";
  {
    std::ofstream(ply, std::ios::binary) << "an earlier export";
  }
  std::filesystem::resize_file(damaged, std::filesystem::file_size(damaged) / 2);
  const ChunkStore store(dir / "map", reader_config(c));
  try {
    export_ply(store, ply, {});
    FAIL() << "a damaged chunk exported";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(damaged.filename().string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_all(ply), "an earlier export");
  size_t files = 0;
  for (const auto& f : std::filesystem::directory_iterator(dir / "out")) ++files, (void)f;
  EXPECT_EQ(files, 1u) << "a temporary was left beside the export";
  std::filesystem::remove(ply);
  EXPECT_THROW(export_ply(store, ply, {}), Error);
  EXPECT_FALSE(std::filesystem::exists(ply));
}

}  // namespace
}  // namespace chungs
