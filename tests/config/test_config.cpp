#include <gtest/gtest.h>

#include "chungs/common/error.hpp"
#include "chungs/config/config.hpp"

using namespace chungs;

TEST(Config, PrintedDefaultsLoadBackToTheSameValues) {
  Config c;
  c.residency.budget_gaussians = 12345;
  c.adam.lr_position = 5e-5f;
  c.raster.background = {0.25, 0.5, 1.0};
  c.store.compress = true;
  Config back = config_from_yaml(config_to_yaml(c));
  EXPECT_EQ(back.residency.budget_gaussians, 12345u);
  EXPECT_FLOAT_EQ(back.adam.lr_position, 5e-5f);
  EXPECT_DOUBLE_EQ(back.raster.background[2], 1.0);
  EXPECT_TRUE(back.store.compress);
  EXPECT_EQ(config_to_yaml(back), config_to_yaml(c));
}

TEST(Config, DefaultsAreThePapers) {
  Config c;
  EXPECT_EQ(c.residency.budget_gaussians, 1'500'000u);
  EXPECT_DOUBLE_EQ(c.store.chunk_size, 10.0);
  EXPECT_DOUBLE_EQ(c.culling.far, 100.0);
  EXPECT_EQ(c.keyframes.max_in_memory, 400u);
  EXPECT_DOUBLE_EQ(c.loss.lambda_ssim, 0.2);
}

TEST(Config, PartialFileKeepsOtherDefaults) {
  Config c = config_from_yaml("residency:\n  budget_gaussians: 2000000\n");
  EXPECT_EQ(c.residency.budget_gaussians, 2'000'000u);
  EXPECT_DOUBLE_EQ(c.store.chunk_size, 10.0);
}

TEST(Config, TyposAndBadValuesNameTheKeyAndLine) {
  auto expect_error = [](const std::string& yaml, const std::string& needle) {
    try {
      config_from_yaml(yaml, "my.yaml");
      FAIL() << "no error for " << yaml;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error("residency:\n  budget: 5\n", "my.yaml:2: unknown key 'residency.budget'");
  expect_error("residence:\n  budget_gaussians: 5\n", "unknown section 'residence'");
  expect_error("store:\n  chunk_size: ten\n", "store.chunk_size");
  expect_error("loss:\n  lambda_ssim: 3\n", "my.yaml");
  expect_error("store: [1, 2\n", "not valid YAML");
  // yaml-cpp read these as octal 8 and hexadecimal 256.
  expect_error("residency:\n  budget_gaussians: 010\n", "my.yaml:2: residency.budget_gaussians: '010'");
  expect_error("residency:\n  budget_gaussians: 0x100\n", "residency.budget_gaussians: '0x100'");
  expect_error("residency:\n  budget_gaussians: 99999999999999999999\n", "residency.budget_gaussians");
  EXPECT_EQ(config_from_yaml("residency:\n  budget_gaussians: 120000\n", "my.yaml").residency.budget_gaussians,
            120000u);
  // A likely typo names the nearest key; a renamed key names what replaced it; a far-off word neither.
  expect_error("sampler:\n  densty: 3\n", "unknown key 'sampler.densty'; did you mean 'sampler.density'?");
  expect_error("samplr:\n  density: 3\n", "unknown section 'samplr'; did you mean 'sampler'?");
  expect_error("sampler:\n  min_per_chunk: 100\n",
               "unknown key 'sampler.min_per_chunk': it became sampler.min_per_chunk_per_100k_px");
  try {
    config_from_yaml("sampler:\n  zzzzzzzzzzzz: 1\n", "my.yaml");
    FAIL() << "no error for an unknown key";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find("did you mean"), std::string::npos) << e.what();
  }
}

TEST(Config, KeysAbsentFromTheFileKeepTheBaseValues) {
  chungs::Config base;
  base.loss.lambda_depth = 0.37;
  base.sampler.fill_depth = 61.0;
  const chungs::Config c = chungs::config_from_yaml("residency:\n  budget_gaussians: 5000\nloss:\n  lambda_ssim: 0.3\n",
                                                    "f.yaml", base);
  EXPECT_EQ(c.residency.budget_gaussians, 5000u);
  EXPECT_DOUBLE_EQ(c.loss.lambda_ssim, 0.3);
  EXPECT_DOUBLE_EQ(c.loss.lambda_depth, 0.37);  // from the base, not the default
  EXPECT_DOUBLE_EQ(c.sampler.fill_depth, 61.0);
}

TEST(Config, StoreAndResidencyValuesOutOfRangeAreRefusedNamingTheKey) {
  for (const auto& [yaml, key] : std::vector<std::pair<std::string, std::string>>{
           {"store: {zstd_level: 9999}", "zstd_level"},
           {"store: {zstd_level: 0}", "zstd_level"},
           {"store: {chunk_size: .nan}", "chunk_size"},
           {"store: {chunk_size: 1e-9}", "chunk_size"},  // chunk ids end 1 mm from the origin
           {"store: {sh_degree: 4}", "sh_degree"},
           {"residency: {flush_threads: -5}", "flush_threads"},
           {"residency: {write_behind_threads: -1}", "write_behind_threads"},
           {"residency: {write_behind_threads: 257}", "write_behind_threads"},
           {"residency: {checkpoint_threads: 0}", "checkpoint_threads"},
           {"residency: {budget_gaussians: 0}", "budget_gaussians"},
           {"residency: {eviction_hysteresis: 1}", "eviction_hysteresis"}}) {
    try {
      chungs::config_from_yaml(yaml, "t.yaml");
      ADD_FAILURE() << yaml << " accepted";
    } catch (const chungs::Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << yaml << ": " << e.what();
    }
  }
  EXPECT_NO_THROW(chungs::config_from_yaml("store: {zstd_level: 22}\nresidency: {flush_threads: 1}", "t.yaml"));
}

TEST(Config, RepeatedKeysAndSectionsAreRefusedNotDropped) {
  // yaml-cpp keeps both of two equal keys and lookups saw the first: the second value was dropped.
  for (const auto& [yaml, needle] : std::vector<std::pair<std::string, std::string>>{
           {"store:\n  chunk_size: 2\n  chunk_size: 3\n", "t.yaml:3: 'store.chunk_size' is given twice"},
           {"store:\n  chunk_size: 2\nstore:\n  sh_degree: 1\n", "t.yaml:3: 'store' is given twice"},
           {"? [a, b]\n: 1\n", "t.yaml:1: a key of the file is not a word"},
           {"store:\n  ? [a]\n  : 1\n", "t.yaml:2: a key of section 'store' is not a word"}}) {
    try {
      chungs::config_from_yaml(yaml, "t.yaml");
      ADD_FAILURE() << yaml << " accepted";
    } catch (const chungs::Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << yaml << ": " << e.what();
    }
  }
}

TEST(Config, CullingAndKeyframeValuesOutOfRangeAreRefusedNamingTheKey) {
  // Neither section had a check: a file's near: -1 or zstd_level: 9999 reached the culler and the store.
  for (const auto& [yaml, needle] : std::vector<std::pair<std::string, std::string>>{
           {"culling: {near: -1}", "t.yaml: culling: near must be"},
           {"culling: {far: .nan}", "culling: far must be"},
           {"culling: {near: 10, far: 1}", "culling: far must be"},
           {"culling: {far: 1e30}", "culling: far must be at most 1e12 times near"},
           {"culling: {near: 1e-300}", "culling: far must be at most 1e12 times near"},
           {"culling: {max_distance: 0}", "culling: max_distance must be"},
           {"culling: {cache_translation: .inf}", "culling: cache_translation must be"},
           {"culling: {cache_rotation_rad: -1}", "culling: cache_rotation_rad must be"},
           {"keyframes: {zstd_level: 9999}", "keyframes: zstd_level must be"}}) {
    try {
      chungs::config_from_yaml(yaml, "t.yaml");
      ADD_FAILURE() << yaml << " accepted";
    } catch (const chungs::Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << yaml << ": " << e.what();
    }
  }
  EXPECT_NO_THROW(
      chungs::config_from_yaml("culling: {near: 0.1, far: 50}\nkeyframes: {zstd_level: 3}", "t.yaml"));
}

TEST(Config, MapperAdamAndStereoValuesAreRefusedNamingTheKeyAndValue) {
  // speed: .inf was taken; beta1: 1.5 said "betas must be in [0, 1)", stereo said "disparities".
  for (const auto& [yaml, needle] : std::vector<std::pair<std::string, std::string>>{
           {"mapper: {speed: .inf}", "mapper: speed must be"},
           {"mapper: {speed: 0.001}", "mapper: speed must be a factor from 0.01 to 1000, got 0.001"},
           {"mapper: {final_iterations: -2}", "mapper: final_iterations must be >= 0, or -1 for one a keyframe"},
           {"mapper: {refinement_rounds: 0}", "mapper: refinement_rounds must be in [1, 1000], got 0"},
           {"mapper: {refinement_rounds: 1001}", "mapper: refinement_rounds must be in [1, 1000], got 1001"},
           {"mapper: {refinement_min_visit_steps: 0}", "mapper: refinement_min_visit_steps must be in [1, 1000000], got 0"},
           {"mapper: {max_saved_renders: -1}", "mapper: max_saved_renders must be >= 0, got -1"},
           {"adam: {beta1: 1.5}", "beta1 must be in [0, 1), got 1.5"},
           {"adam: {beta2: -0.5}", "beta2 must be in [0, 1), got -0.5"},
           {"stereo: {num_disparities: 1000}", "num_disparities must be in [16, 256], got 1000"}}) {
    try {
      chungs::config_from_yaml(yaml, "t.yaml");
      ADD_FAILURE() << yaml << " accepted";
    } catch (const chungs::Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << yaml << ": " << e.what();
    }
  }
}

TEST(Config, RefinementStepsAreOneAKeyframeInEitherPacingOrAsGiven) {
  Config c;
  EXPECT_EQ(c.mapper.final_iterations, -1);
  EXPECT_EQ(c.mapper.refinement_steps(1034), 1034u);
  // A map of few keyframes under fixed pacing: four keyframes' worth of steps at least.
  EXPECT_EQ(c.mapper.refinement_steps(1), 120u);
  EXPECT_EQ(c.mapper.refinement_steps(121), 121u);
  EXPECT_EQ(config_from_yaml("mapper: {iterations_per_keyframe: 10}").mapper.refinement_steps(3), 40u);
  c = config_from_yaml("mapper: {pacing: anytime}");
  EXPECT_EQ(c.mapper.refinement_steps(1034), 1034u);
  EXPECT_EQ(c.mapper.refinement_steps(1), 1u);
  c = config_from_yaml("mapper: {pacing: anytime, final_iterations: 7}");
  EXPECT_EQ(c.mapper.refinement_steps(1034), 7u);
  c = config_from_yaml("mapper: {final_iterations: 0}");
  EXPECT_EQ(c.mapper.refinement_steps(1034), 0u);
  EXPECT_EQ(Config().mapper.refinement_rounds, 16);
  EXPECT_EQ(config_from_yaml("mapper: {refinement_rounds: 16}").mapper.refinement_rounds, 16);
}

TEST(Config, AutomaticRefinementGivesEveryGroupItsStepsUpToSixteenAKeyframeOrHalfTheDrive) {
  Config c;  // 128 steps a group when there are several
  EXPECT_EQ(c.mapper.refinement_group_steps, 128);
  EXPECT_EQ(c.mapper.refinement_steps(1034, 1), 1034u);
  EXPECT_EQ(c.mapper.refinement_steps(1034, 5), 1034u);       // 640 < one a keyframe
  EXPECT_EQ(c.mapper.refinement_steps(1034, 100), 12800u);
  EXPECT_EQ(c.mapper.refinement_steps(1034, 162), 16544u);    // 2 km street under 100 k: 16 a keyframe
  EXPECT_EQ(c.mapper.refinement_steps(1, 2), 120u);           // fixed pacing's least
  c = config_from_yaml("mapper: {refinement_group_steps: 3}");
  EXPECT_EQ(c.mapper.refinement_steps(100, 50), 150u);
  c = config_from_yaml("mapper: {pacing: anytime, refinement_group_steps: 0}");
  EXPECT_EQ(c.mapper.refinement_steps(500, 20), 500u);
  c = config_from_yaml("mapper: {pacing: anytime}");
  EXPECT_EQ(c.mapper.refinement_steps(500, 20), 2560u);
  // Never more than the drive's own steps: 5 a keyframe over 500 keyframes.
  EXPECT_EQ(c.mapper.refinement_steps(500, 20, 2500), 2500u);
  EXPECT_EQ(c.mapper.refinement_steps(500, 20, 100), 500u);  // one a keyframe still
  EXPECT_EQ(Config().mapper.refinement_steps(1034, 162, 31020), 16544u);  // 2 km street, 30 a keyframe
  EXPECT_EQ(Config().mapper.refinement_steps(1034, 175, 32881), 16544u);  // 72 km/h, 31.8 a keyframe
  // A drive of 65 steps a keyframe (36 km/h): 4 x 65 a group, up to half the drive's steps.
  EXPECT_EQ(Config().mapper.refinement_steps(1034, 134, 67210), 33605u);
  EXPECT_EQ(Config().mapper.refinement_steps(1034, 100, 67210), 26000u);
  EXPECT_EQ(Config().mapper.refinement_steps(1034, 10, 67210), 2600u);   // 300 k: 10 groups
  EXPECT_EQ(Config().mapper.refinement_steps(1034, 2, 67210), 1034u);    // the default budget: one a keyframe
  // Without the drive's steps the cap is 16 a keyframe and a group gets refinement_group_steps.
  EXPECT_EQ(Config().mapper.refinement_steps(1034, 300), 16544u);
  EXPECT_EQ(config_from_yaml("mapper: {refinement_group_steps: 0}").mapper.refinement_steps(1034, 134, 67210), 1034u);
  // Steps given are the steps run, whatever the groups.
  EXPECT_EQ(config_from_yaml("mapper: {final_iterations: 7}").mapper.refinement_steps(1034, 162), 7u);
  EXPECT_THROW(config_from_yaml("mapper: {refinement_group_steps: -1}"), chungs::Error);
}

TEST(Config, DepthRefinementKeysLoadAndBadRangesAreRefusedByName) {
  const chungs::Config c = chungs::config_from_yaml(
      "multiview:\n  refine: on\n  refine_rgbd_range: 0.1\n  refine_stereo_range: 0.02\n", "r.yaml");
  EXPECT_TRUE(c.multiview.refine);
  EXPECT_DOUBLE_EQ(c.multiview.refine_rgbd_range, 0.1);
  EXPECT_DOUBLE_EQ(c.multiview.refine_stereo_range, 0.02);
  EXPECT_FALSE(chungs::config_from_yaml("multiview:\n  refine: off\n").multiview.refine);
  for (const auto& [yaml, needle] : std::vector<std::pair<std::string, std::string>>{
           {"multiview: {refine_rgbd_range: 0}", "got 0"},
           {"multiview: {refine_stereo_range: -0.01}", "got -0.01"},
           {"multiview: {refine_stereo_range: .nan}", "refine_stereo_range"},
           {"multiview: {refine: maybe}", "multiview.refine"}}) {
    try {
      chungs::config_from_yaml(yaml, "t.yaml");
      ADD_FAILURE() << yaml << " accepted";
    } catch (const chungs::Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << yaml << ": " << e.what();
    }
  }
}
