// Mapping from one camera (issue 25): keyframes get depth from a plane sweep against earlier ones
// (pipeline/multiview_keyframes.hpp). A street seen by its left camera maps close to its stereo run;
// the multiview depth of its keyframes is checked against the rendered depth; the first keyframe,
// which has no earlier one, is sampled once a later one gives it a neighbour; one frame or black
// frames give an empty but valid map, not a failure.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "chungs/common/log.hpp"
#include "chungs/common/error.hpp"
#include "chungs/config/presets.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/datasets/mono_view.hpp"
#include "chungs/pipeline/multiview_keyframes.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "chungs/synth/street_dataset.hpp"
#include "mapping/synthetic_sequence.hpp"
#include "mapping/tiny_config.hpp"
#include "test_support.hpp"

namespace chungs {
namespace {

synth::StreetDatasetOptions street_options(bool depth) {
  synth::StreetDatasetOptions so;
  so.street.length_m = 60;
  so.street.seed = 7;
  so.width = 310;
  so.height = 94;
  so.depth = depth;
  return so;
}

// The defaults with the outdoor preset `run` picks for a street, at test size.
Config street_config() {
  Config c;
  apply_preset(c, "outdoor", "");
  c.mapper.device = "cpu";
  c.mapper.iterations_per_keyframe = 10;
  c.mapper.final_iterations = 50;
  c.mapper.eval_keyframe_stride = 0;
  c.mapper.max_saved_renders = 0;
  c.store.durable = false;
  c.keyframes.durable = false;
  c.validate();
  return c;
}

nlohmann::json map(const Dataset& data, const std::filesystem::path& out, const Config& c, const char* name) {
  RunOptions o;
  o.dataset = name;
  o.out = out;
  o.config = c;
  return run_mapping(o, data);
}

// The 60 m street's 310x94 left camera alone against both cameras, with the same poses and settings.
// The bound: 3 dB, against the 2 dB for a long run, because this run is short (its first
// keyframes, where the sweep has the fewest neighbours, weigh more) and single (threads make runs
// differ by a few tenths of a dB).
TEST(MonoRun, AStreetFromOneCameraMapsCloseToItsStereoRun) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const synth::StreetDataset stereo(street_options(false));
  const auto mono = with_input_mode(std::make_unique<synth::StreetDataset>(street_options(false)), InputMode::Mono);
  const nlohmann::json rs = map(stereo, dir / "stereo", street_config(), "synth-street:stereo");
  const nlohmann::json rm = map(*mono, dir / "mono", street_config(), "synth-street:mono");
  const double ps = rs["held_out"]["mean_psnr"], pm = rm["held_out"]["mean_psnr"];
  std::printf("held-out PSNR: stereo %.2f dB, mono %.2f dB; Gaussians %llu / %llu; multiview %s\n", ps, pm,
              (unsigned long long)rs["gaussians"]["total"].get<uint64_t>(),
              (unsigned long long)rm["gaussians"]["total"].get<uint64_t>(), rm["multiview"].dump().c_str());
  EXPECT_EQ(rm["depth"], "multiview");
  EXPECT_GT(rm["gaussians"]["total"].get<uint64_t>(), 1000u);
  EXPECT_GT(pm, ps - 3.0);
  // Swept depth is a guess: the run raises the position rate for it (adam.multiview_position_factor).
  EXPECT_NEAR(rm["settings"]["lr_position"].get<double>(),
              rs["settings"]["lr_position"].get<double>() * AdamConfig().multiview_position_factor, 1e-9);
  EXPECT_EQ(rm["multiview"]["deferred"].get<size_t>(), 1u);  // the first keyframe
  EXPECT_EQ(rm["multiview"]["deferred_then_sampled"].get<size_t>(), 1u);
}

// One camera's tracker sets the map's unit at its first keyframe; `run` sets that keyframe's median depth
// to multiview.scene_depth metres (10 outdoors) so that the metric settings keep their sense. The street's
// views are 5-20 m deep, so the unit is within a factor 2 of a metre (it was ~1/10 of the tracker's own
// convention, median depth 1), and twice the setting gives a map twice as large.
TEST(MonoRun, ATrackedMapFromOneCameraIsNearlyInMetres) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  synth::StreetDatasetOptions so = street_options(false);
  so.width = 620;  // the tracker needs more than 310x94 (bench/README.md, "Monocular tracking")
  so.height = 188;
  so.max_frames = 24;
  const auto mono = with_input_mode(std::make_unique<synth::StreetDataset>(so), InputMode::Mono);
  Config c = street_config();
  c.mapper.iterations_per_keyframe = 1;
  c.mapper.final_iterations = 0;
  c.mapper.resolution = 0.5;
  auto scale = [&](double scene_depth, const char* name) {
    c.multiview.choice.scene_depth = scene_depth;
    RunOptions o;
    o.dataset = "synth-street:mono";
    o.out = dir / name;
    o.config = c;
    o.poses = "track";
    const nlohmann::json r = run_mapping(o, *mono);
    EXPECT_EQ(r["tracking"]["map_segments"].get<int>(), 1) << name;
    EXPECT_EQ(r["tracking"]["ate"]["alignment"], "sim3") << name;
    // The alignment's scale takes the tracker's units to metres.
    return r["tracking"]["ate"]["transform"]["scale"].get<double>();
  };
  const double s10 = scale(10, "unit10"), s20 = scale(20, "unit20");
  std::printf("metres per map unit: %.3f (scene depth 10 m), %.3f (20 m)\n", s10, s20);
  EXPECT_GT(s10, 0.5);
  EXPECT_LT(s10, 2.0);
  EXPECT_NEAR(s20, s10 / 2, 0.1 * s10);
}

// Frame i of the street registered as a keyframe at its true pose, as the run's feed does.
void register_keyframe(MultiviewKeyframes& mv, const synth::StreetDataset& street, size_t i) {
  FeedItem item;
  item.frame = i;
  item.pose = street.gt_pose(i);
  item.keyframe = true;
  item.keyframe_id = long(i);
  mv.seen(item);
}

// A keyframe's depth is what its registration fixed: computed at once, or after later keyframes have
// pushed its neighbours out of the window and a new scene depth is known (a load runs whenever a
// worker takes it), the same map. Read at load time, those had made fixed pacing's runs differ.
TEST(MultiviewKeyframes, ADepthDoesNotDependOnWhenItsLoadRuns) {
  const synth::StreetDataset street(street_options(false));
  MultiviewDepthConfig config;
  config.keep_keyframes = 3;
  const std::vector<size_t> frames{0, 2, 4, 6};
  std::map<size_t, std::vector<float>> at_once, later;
  MultiviewKeyframes a(street, 1.0, config, false, true, nullptr);
  for (size_t i : frames) {
    register_keyframe(a, street, i);
    if (auto d = a.depth(i, street.frame(i).left).depth) at_once[i] = d->vec();
  }
  // Frames 2 and 4 load after frame 6 has pushed frame 0 out of the window and a scene depth is known.
  MultiviewKeyframes b(street, 1.0, config, false, true, nullptr);
  for (size_t i : {0, 2, 4}) register_keyframe(b, street, i);
  EXPECT_FALSE(b.depth(0, street.frame(0).left).depth) << "the first keyframe waits for a neighbour";
  b.set_scene_depth(2.0);
  register_keyframe(b, street, 6);
  for (size_t i : {2, 4, 6})
    if (auto d = b.depth(i, street.frame(i).left).depth) later[i] = d->vec();
  for (size_t i : {2, 4}) {
    ASSERT_TRUE(at_once.count(i)) << "frame " << i << " has a neighbour";
    ASSERT_TRUE(later.count(i)) << "frame " << i << ": its neighbours were pushed out of the window before its load";
    EXPECT_EQ(at_once[i], later[i]) << "frame " << i;
  }
}

// Keyframes every 2 m of the same street, swept against each other as a run does, scored against the
// rendered depth. The bound 0.15 leaves room above the plane sweep's 0.07-0.11 on the street
// (bench/README.md) for the spread between grid points.
TEST(MultiviewKeyframes, StreetDepthAgainstRenderedDepth) {
  const synth::StreetDataset street(street_options(true));
  MultiviewDepthConfig c;
  c.fill_holes = false;  // as run has it outdoors, where the sampler's fill depth takes the sky
  MultiviewKeyframes mv(street, 1.0, c, false, true, nullptr);
  std::vector<size_t> frames;
  for (size_t i = 0; i < std::min<size_t>(street.size(), 24); i += 2) frames.push_back(i);
  for (size_t i : frames) register_keyframe(mv, street, i);
  double sum = 0;
  size_t valid = 0, truth = 0, late = 0;
  auto score = [&](const ImageF& est, const ImageF& gt) {
    for (size_t k = 0; k < est.pixels(); ++k) {
      const float g = gt.vec()[k], e = est.vec()[k];
      if (!(g > 0 && g < 80)) continue;  // the sky has no depth to compare
      ++truth;
      if (!(e > 0)) continue;
      ++valid;
      sum += std::abs(e - g) / g;
    }
  };
  size_t with_depth = 0;
  for (size_t i : frames) {
    const Frame f = street.frame(i);
    MultiviewKeyframes::Result r = mv.depth(i, f.left);
    EXPECT_EQ(r.depth.has_value(), i != frames.front()) << "frame " << i;
    if (r.depth) score(*r.depth, *f.depth), ++with_depth;
    for (auto& [frame, depth] : r.late) {
      ++late, ++with_depth;
      EXPECT_EQ(frame, frames.front());
      score(depth, *street.frame(frame).depth);
    }
  }
  EXPECT_EQ(with_depth, frames.size());
  const double abs_rel = sum / double(std::max<size_t>(valid, 1)), coverage = double(valid) / double(truth);
  std::printf("street keyframes: AbsRel %.4f over %.1f %% of the pixels with depth below 80 m; %s\n", abs_rel,
              100 * coverage, mv.report().dump().c_str());
  EXPECT_EQ(late, 1u);
  EXPECT_LT(abs_rel, 0.15);
  EXPECT_GT(coverage, 0.3);
}

// The tiny wall seen by one camera: the first keyframe's depth waits for the second, and both are
// sampled. Its focal length (50 px) moves the image less per keyframe than the default parallax test
// asks, so that is relaxed as in the plane sweep's tests; and its checker repeats every 8 px, which
// the default range (0.5-80 m: 25 px of disparity here) would find several times over, so the sweep
// is kept to 2-10 m around the wall at 3 m.
Config wall_config() {
  Config c = test::tiny_mapping_config();
  c.multiview.sweep.max_rel_per_px = 0.5;
  c.multiview.sweep.best_k = 1;
  c.multiview.sweep.near = 2.0;
  c.multiview.sweep.far = 10.0;
  return c;
}

TEST(MonoRun, TheFirstKeyframeIsSampledOnceALaterOneGivesItANeighbour) {
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const auto wall = with_input_mode(std::make_unique<test::WallSequence>(12, 64, 48, 0.25), InputMode::Mono);
  const nlohmann::json r = map(*wall, dir / "map", wall_config(), "synthetic:mono-wall");
  std::printf("mono wall: %llu Gaussians, held-out PSNR %.2f dB, %s\n",
              (unsigned long long)r["gaussians"]["total"].get<uint64_t>(), r["held_out"]["mean_psnr"].get<double>(),
              r["multiview"].dump().c_str());
  EXPECT_EQ(r["multiview"]["deferred"].get<size_t>(), 1u);
  EXPECT_EQ(r["multiview"]["deferred_then_sampled"].get<size_t>(), 1u);
  EXPECT_GT(r["gaussians"]["total"].get<uint64_t>(), 100u);
  // 21.2 dB measured (13.8-15.0 with min_confidence 0.5); an almost empty map (241 Gaussians) scored 8.1.
  EXPECT_GT(r["held_out"]["mean_psnr"].get<double>(), 12.0);
}

// One camera and no keyframe with depth: the run fails naming why (it used to score the empty map,
// 4 dB, with exit 0), and leaves a folder that reopens with what it committed.
void expect_empty_map_refused(const Dataset& data, const std::filesystem::path& out, const char* name,
                              const std::string& frames) {
  try {
    map(data, out, wall_config(), name);
    ADD_FAILURE() << name << ": an empty map was accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no keyframe got depth from its neighbours"), std::string::npos) << m;
    EXPECT_NE(m.find(frames + "), so the map is empty"), std::string::npos) << m;
    // The message says what the folder holds: a committed empty map, which a new run is refused (and
    // --resume ends the same way), or nothing yet, where a new run starts afresh.
    EXPECT_TRUE(m.find(out.string() + " is left with that empty map: remove it") != std::string::npos ||
                m.find("nothing was committed to " + out.string()) != std::string::npos)
        << m;
  }
  Mapper reopened(out, wall_config(), true);  // what the run committed before it failed (maybe nothing yet)
  EXPECT_EQ(reopened.total_gaussians(), 0u);
  EXPECT_FALSE(std::filesystem::exists(out / "report.json"));
}

TEST(MonoRun, OneFrameIsRefusedAsAnEmptyMapAndItsFolderReopens) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  const auto wall = with_input_mode(std::make_unique<test::WallSequence>(1, 64, 48), InputMode::Mono);
  expect_empty_map_refused(*wall, dir / "map", "synthetic:one-frame", "over its 1 frame");
}

class BlackWall : public test::WallSequence {
 public:
  using WallSequence::WallSequence;
  Frame frame(size_t i) const override {
    Frame f = WallSequence::frame(i);
    std::fill(f.left.vec().begin(), f.left.vec().end(), uint8_t(0));
    return f;
  }
};

TEST(MonoRun, BlackFramesAreRefusedAsAnEmptyMapAndTheirFolderReopens) {
  log::set_level(log::Level::Error);
  test::TempDir dir;
  // No texture: the sweep keeps no pixel, although the camera moved.
  const auto black = with_input_mode(std::make_unique<BlackWall>(10, 64, 48, 0.25), InputMode::Mono);
  expect_empty_map_refused(*black, dir / "map", "synthetic:black", "over its 10 frames");
}

}  // namespace
}  // namespace chungs
