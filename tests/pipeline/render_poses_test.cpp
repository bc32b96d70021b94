// Rendering a finished map folder outside the mapper: the same pictures the mapper's own evaluation
// scored, bounded memory under a small budget, PNGs along a trajectory, and errors that name the folder.
#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/log.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/pipeline/render_poses.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/store/chunk_store.hpp"
#include "mapping/synthetic_sequence.hpp"
#include "test_support.hpp"
#include "mapping/tiny_config.hpp"

namespace chungs {
namespace {

Config small_map_config() {
  Config c = test::tiny_mapping_config();
  c.store.chunk_size = 0.5;  // several chunks along the wall, so a small budget has to stream
  c.mapper.iterations_per_keyframe = 8;
  c.mapper.final_iterations = 40;
  c.mapper.checkpoint_every = 5;
  return c;
}

// One small map shared by the tests of this file (mapping it is the slow part).
struct SmallMap {
  test::TempDir dir;
  test::WallSequence seq{16, 64, 48, 0.3};  // 4.5 m along the wall: views do not all overlap
  Config config = small_map_config();
  nlohmann::json report;
  SmallMap() {
    log::set_level(log::Level::Warn);
    RunOptions o;
    o.dataset = "synthetic:wall";
    o.out = dir / "map";
    o.config = config;
    report = run_mapping(o, seq);
  }
  std::filesystem::path map() const { return dir / "map"; }
  std::vector<std::optional<SE3>> poses() const {
    std::vector<std::optional<SE3>> p;
    for (size_t i = 0; i < seq.size(); ++i) p.push_back(seq.gt_pose(i));
    return p;
  }
};

SmallMap& small_map() {
  static SmallMap m;
  return m;
}

TEST(RenderPoses, ScoresHeldOutFramesAsTheMapperDid) {
  SmallMap& m = small_map();
  MapRenderer r(m.map(), m.config);
  test::TempDir out;
  const RenderPosesSummary s = render_dataset(r, m.seq, m.poses(), 1.0, out.path(), 1, true);
  ASSERT_EQ(s.views.size(), m.seq.size());
  ASSERT_EQ(s.scored, m.seq.size());
  size_t compared = 0;
  for (const auto& hv : m.report["held_out"]["views"]) {
    const size_t f = hv["frame"].get<size_t>();
    ASSERT_TRUE(s.views[f].metrics);
    EXPECT_NEAR(s.views[f].metrics->psnr, hv["psnr"].get<double>(), 0.05) << "frame " << f;
    EXPECT_NEAR(s.views[f].metrics->ssim, hv["ssim"].get<double>(), 2e-3) << "frame " << f;
    ++compared;
  }
  EXPECT_EQ(compared, 2u);  // frames 7 and 15 of 16 are held out
  EXPECT_GT(s.mean_psnr, 15.0);
  // --stack: render above the image.
  const Image8 png = read_image8(out.path() / "render_000003.png");
  EXPECT_EQ(png.width(), 64);
  EXPECT_EQ(png.height(), 96);
}

// A map whose cubes have two levels is drawn at the levels its own distance chose, whatever the
// reader's settings say: the far level of a cube is what views from beyond it were trained on.
TEST(RenderPoses, AMapWithTwoLevelsIsDrawnAtItsOwnDistanceWhateverTheSettingsSay) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  test::WallSequence seq{16, 64, 48, 0.3};
  RunOptions o;
  o.dataset = "synthetic:wall";
  o.out = dir / "map";
  o.config = small_map_config();
  o.config.culling.far_level_distance = 3.2;  // the wall 3 m ahead: cubes in front near, those aside far
  const nlohmann::json report = run_mapping(o, seq);
  size_t far = 0, near = 0;
  {
    const ChunkStore store(dir / "map", reader_config());
    EXPECT_EQ(store.config_value("far_level_distance"), std::optional<std::string>("3.2"));
    for (ChunkId id : store.ids()) (is_far_level(id) ? far : near)++;
  }
  EXPECT_GT(far, 2u);
  EXPECT_GT(near, 2u);
  for (double setting : {0.0, 70.0}) {
    Config c = o.config;
    c.culling.far_level_distance = setting;
    MapRenderer r(dir / "map", c);
    test::TempDir out;
    std::vector<std::optional<SE3>> poses;
    for (size_t i = 0; i < seq.size(); ++i) poses.push_back(seq.gt_pose(i));
    const RenderPosesSummary s = render_dataset(r, seq, poses, 1.0, out.path(), 1, false);
    for (const auto& hv : report["held_out"]["views"]) {
      const size_t f = hv["frame"].get<size_t>();
      ASSERT_TRUE(s.views[f].metrics);
      EXPECT_NEAR(s.views[f].metrics->psnr, hv["psnr"].get<double>(), 0.05) << "frame " << f << ", setting " << setting;
    }
  }
}

TEST(RenderPoses, StreamsChunksUnderABudgetBelowTheMapWithTheSamePictures) {
  SmallMap& m = small_map();
  test::TempDir out;
  uint64_t total = 0;
  double full_psnr = 0;
  uint64_t largest_view = 0;
  {
    MapRenderer full(m.map(), m.config);  // one opener at a time: the folder is locked while open
    total = full.total_gaussians();
    full_psnr = render_dataset(full, m.seq, m.poses(), 1.0, out.path()).mean_psnr;
    largest_view = full.largest_view_gaussians();
  }
  const uint64_t chunks = m.report["gaussians"]["chunks"].get<uint64_t>();
  ASSERT_GT(chunks, 3u);
  // A budget that holds every single view but not the whole map.
  ASSERT_LT(largest_view, total);
  Config c = m.config;
  c.residency.budget_gaussians = size_t(largest_view);
  c.residency.async_io = false;
  MapRenderer small(m.map(), c);
  const RenderPosesSummary s = render_dataset(small, m.seq, m.poses(), 1.0, out.path());
  EXPECT_EQ(s.views.size(), m.seq.size());
  EXPECT_EQ(small.chunks_skipped(), 0u);
  EXPECT_NEAR(s.mean_psnr, full_psnr, 1e-3);  // streaming changes no pixel
  EXPECT_LE(small.peak_resident_gaussians(), c.residency.budget_gaussians);
  // A second pass from the start reloads the chunks evicted on the way along the wall.
  render_dataset(small, m.seq, m.poses(), 1.0, out.path());
  EXPECT_GT(small.io_stats().loads, chunks);
  EXPECT_LE(small.peak_resident_gaussians(), c.residency.budget_gaussians);
  EXPECT_EQ(small.views_in_passes(), 0u);
}

TEST(RenderPoses, ViewsBeyondTheBudgetAreDrawnWholeInPasses) {
  SmallMap& m = small_map();
  test::TempDir out;
  double full_psnr = 0;
  uint64_t largest_view = 0;
  {
    MapRenderer full(m.map(), m.config);
    full_psnr = render_dataset(full, m.seq, m.poses(), 1.0, out.path()).mean_psnr;
    largest_view = full.largest_view_gaussians();
  }
  Config c = m.config;
  c.residency.budget_gaussians = size_t(largest_view * 6 / 10);
  c.residency.async_io = false;
  MapRenderer small(m.map(), c);
  const RenderPosesSummary s = render_dataset(small, m.seq, m.poses(), 1.0, out.path());
  std::printf("PSNR %.3f dB whole, %.3f in passes; %zu views in passes, %zu chunks left out\n", full_psnr,
              s.mean_psnr, small.views_in_passes(), small.chunks_skipped());
  EXPECT_GT(small.views_in_passes(), 0u);
  EXPECT_LE(small.peak_resident_gaussians(), c.residency.budget_gaussians);
  // Splats overhanging a chunk face between two passes are ordered by chunk there, not by depth.
  // This wall lies on a chunk face (z = 3 m, chunks of 0.5 m), the worst case: its splats straddle
  // two chunks everywhere (-1.4 dB). On a street map, 53-86 views in passes cost 0.001-0.02 dB
  // (bench/README.md); without the far chunks their pixels showed the background.
  EXPECT_GT(s.mean_psnr, full_psnr - 2.0);
}

TEST(RenderPoses, WritesOnePngPerPoseWithTheMapsCamera) {
  SmallMap& m = small_map();
  MapRenderer r(m.map(), m.config);
  EXPECT_EQ(r.mapping_camera().width, 64);
  Trajectory t;
  for (size_t i = 0; i < 6; ++i) t.push_back(0.1 * double(i), *m.seq.gt_pose(i));
  test::TempDir out;
  const RenderPosesSummary s = render_trajectory(r, t, r.mapping_camera().scaled(0.5), out.path(), 2);
  ASSERT_EQ(s.views.size(), 3u);
  EXPECT_EQ(s.scored, 0u);
  for (size_t i : {0, 2, 4}) {
    const std::filesystem::path f = out.path() / ("render_00000" + std::to_string(i) + ".png");
    ASSERT_TRUE(std::filesystem::exists(f)) << f;
    const Image8 img = read_image8(f);
    EXPECT_EQ(img.width(), 32);
    EXPECT_EQ(img.height(), 24);
    // The wall fills the view: a render with content, not the background.
    double mean = 0;
    for (uint8_t v : img.vec()) mean += v;
    EXPECT_GT(mean / double(img.vec().size()), 20.0);
  }
  EXPECT_FALSE(std::filesystem::exists(out.path() / "render_000001.png"));
}

// A run that failed after committing checkpoint K but before renaming its keyframe list leaves the
// list under its numbered name; the map is checkpoint K all the same, and a reader (which renames
// nothing) takes that list rather than the previous one, or none ("no keyframes.txt, so no camera").
TEST(RenderPoses, ReadsTheCommittedKeyframeListStillUnderItsCheckpointName) {
  SmallMap& m = small_map();
  test::TempDir dir;
  const auto map = dir / "map";
  std::filesystem::copy(m.map(), map, std::filesystem::copy_options::recursive);
  uint64_t seq;
  {
    ChunkStore store(map, reader_config());
    seq = std::stoull(store.config_value("checkpoint").value());
  }
  auto records = read_keyframe_records(map / "keyframes.txt");
  std::filesystem::rename(map / "keyframes.txt", checkpoint_file(map, seq, "keyframes.txt"));
  MapRenderer r(map, m.config);
  EXPECT_EQ(r.mapping_camera().width, records.front().camera.width);
  records.resize(1);
  records.front().camera.width = 7;  // an older checkpoint's list under the final name loses
  write_keyframe_records(map / "keyframes.txt", records, false);
  MapRenderer again(map, m.config);
  EXPECT_NE(again.mapping_camera().width, 7);
  EXPECT_TRUE(std::filesystem::exists(checkpoint_file(map, seq, "keyframes.txt")));  // nothing renamed
}

TEST(RenderPoses, RefusesAFolderWithoutAMapAndNamesIt) {
  test::TempDir dir;
  try {
    MapRenderer r(dir / "nomap", Config{});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nomap"), std::string::npos) << e.what();
  }
}

// render takes the map's budget from report.json: a damaged value is refused naming the file and
// the key (-5 was taken as 2^64 - 5 and ended in "cannot create std::vector larger than max_size()",
// a string in a bare json type_error).
TEST(RenderPoses, ADamagedBudgetInTheReportIsRefusedNamingFileAndKey) {
  test::TempDir dir;
  const auto report = dir / "report.json";
  auto put = [&](const std::string& text) { std::ofstream(report) << text; };
  EXPECT_EQ(map_budget_from_report(dir.path()), 0u);  // no report: the config's budget
  put(R"({"settings": {"budget_gaussians": 250000}})");
  EXPECT_EQ(map_budget_from_report(dir.path()), 250'000u);
  put(R"({"settings": {}})");
  EXPECT_EQ(map_budget_from_report(dir.path()), 0u);
  for (const char* bad : {"-5", "0", "1.5", "\"many\"", "null", "99999999999999999999", "4294967296"}) {
    put(std::string(R"({"settings": {"budget_gaussians": )") + bad + "}}");
    try {
      map_budget_from_report(dir.path());
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("report.json"), std::string::npos) << m;
      EXPECT_NE(m.find("settings.budget_gaussians"), std::string::npos) << m;
    }
  }
  for (const char* bad : {"[1]", R"({"settings": 3})"}) {
    put(bad);
    try {
      map_budget_from_report(dir.path());
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("report.json"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace chungs
