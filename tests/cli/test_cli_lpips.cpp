// `eval images` with and without LPIPS weights: without them the output says LPIPS is not
// available and why, and no number appears in its place; a bad weights flag is one error line.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <fstream>
#include <random>

#include "chungs/eval/lpips_weights.hpp"
#include "chungs/image/image_io.hpp"
#include "cli/cli_support.hpp"
#include "eval/lpips_fixtures.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;
namespace fs = std::filesystem;

namespace {

struct Pairs {
  chungs::test::TempDir dir;
  std::string args;
  Pairs() {
    std::mt19937 rng(3);
    const chungs::ImageF a = chungs::test::random_image(48, 40, 3, rng);
    chungs::write_png(dir / "ref/a.png", chungs::to_u8(a));
    chungs::write_png(dir / "test/a.png", chungs::to_u8(chungs::test::with_noise(a, 0.1f, rng)));
    chungs::write_png(dir / "ref/same.png", chungs::to_u8(a));
    chungs::write_png(dir / "test/same.png", chungs::to_u8(a));
    args = "eval images --ref " + (dir / "ref").string() + " --test " + (dir / "test").string();
  }
};

}  // namespace

TEST(CliLpips, WithoutWeightsSaysNotAvailableAndPrintsNoNumber) {
  Pairs p;
  auto r = run_cli("-q " + p.args);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("LPIPS: not available (no --lpips-weights given)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("LPIPS 0"), std::string::npos) << r.out;
  r = run_cli("-q " + p.args + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["mean_lpips"].is_null());
  EXPECT_EQ(j["lpips_unavailable"], "no --lpips-weights given");
  for (const auto& im : j["images"]) EXPECT_TRUE(im["lpips"].is_null());
}

TEST(CliLpips, WithWeightsScoresEveryPairAndIdenticalIsZero) {
  Pairs p;
  chungs::write_lpips_weights(p.dir / "w.dclpips", chungs::test::random_lpips_weights(9));
  auto r = run_cli("-q " + p.args + " --json --lpips-weights " + (p.dir / "w.dclpips").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_FALSE(j.contains("lpips_unavailable"));
  double sum = 0;
  for (const auto& im : j["images"]) {
    ASSERT_TRUE(im["lpips"].is_number()) << im.dump();
    if (im["name"] == "same") EXPECT_EQ(im["lpips"].get<double>(), 0.0);
    if (im["name"] == "a") EXPECT_GT(im["lpips"].get<double>(), 0.0);
    sum += im["lpips"].get<double>();
  }
  EXPECT_NEAR(j["mean_lpips"].get<double>(), sum / 2, 1e-12);
  r = run_cli("-q " + p.args + " --lpips-weights " + (p.dir / "w.dclpips").string());
  EXPECT_NE(r.out.find("LPIPS 0.0000"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("not available"), std::string::npos) << r.out;
}

TEST(CliLpips, BadWeightsFlagIsOneErrorNamingTheFile) {
  Pairs p;
  auto r = run_cli(p.args + " --lpips-weights " + (p.dir / "absent.dclpips").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--lpips-weights: " + (p.dir / "absent.dclpips").string()), std::string::npos) << r.out;
  chungs::write_png(p.dir / "not_weights.png", chungs::Image8(4, 4, 3));
  r = run_cli(p.args + " --lpips-weights " + (p.dir / "not_weights.png").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("not an LPIPS weights file"), std::string::npos) << r.out;
  r = run_cli(p.args + " --lpips-weights ''");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--lpips-weights must be a weights file"), std::string::npos) << r.out;
  chungs::write_lpips_weights(p.dir / "w.dclpips", chungs::test::random_lpips_weights(9));
  chungs::write_png(p.dir / "mask.png", chungs::Image8(48, 40, 1, 255));
  r = run_cli(p.args + " --mask " + (p.dir / "mask.png").string() + " --lpips-weights " +
              (p.dir / "w.dclpips").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("LPIPS has no masked form"), std::string::npos) << r.out;
}

namespace {

chungs::test::CliResult run_street(const fs::path& out, const std::string& extra) {
  return run_cli("-q run --dataset synth-street:length=12,width=160,height=48,seed=2 --device cpu --max-frames 8 "
                 "--iterations 2 --out " + out.string() + " " + extra);
}

nlohmann::json report_of(const fs::path& map) {
  std::ifstream f(map / "report.json");
  return nlohmann::json::parse(f, nullptr, false);
}

}  // namespace

TEST(CliLpips, RunReportsLpipsOnlyWithWeights) {
  chungs::test::TempDir dir;
  auto r = run_street(dir / "plain", "");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("LPIPS: not available (no --lpips-weights or mapper.lpips_weights given)"), std::string::npos)
      << r.out;
  nlohmann::json j = report_of(dir / "plain");
  ASSERT_TRUE(j.contains("held_out")) << j.dump();
  EXPECT_TRUE(j["held_out"]["mean_lpips"].is_null());
  EXPECT_EQ(j["held_out"]["lpips_unavailable"], "no --lpips-weights or mapper.lpips_weights given");
  for (const auto& v : j["held_out"]["views"]) EXPECT_TRUE(v["lpips"].is_null());

  // Through the configuration key, as a benchmark's file would give it.
  chungs::write_lpips_weights(dir / "w.dclpips", chungs::test::random_lpips_weights(12));
  std::ofstream(dir / "lpips.yaml") << "mapper:\n  lpips_weights: " << (dir / "w.dclpips").string() << "\n";
  r = run_street(dir / "scored", "--config " + (dir / "lpips.yaml").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("LPIPS 0."), std::string::npos) << r.out;
  j = report_of(dir / "scored");
  ASSERT_TRUE(j["held_out"]["mean_lpips"].is_number()) << j["held_out"].dump();
  EXPECT_GT(j["held_out"]["mean_lpips"].get<double>(), 0.0);
  EXPECT_FALSE(j["held_out"].contains("lpips_unavailable"));
  EXPECT_TRUE(j["keyframes_eval"]["mean_lpips"].is_number());
}

TEST(CliLpips, RunRefusesABadWeightsFileBeforeMapping) {
  chungs::test::TempDir dir;
  auto r = run_street(dir / "map", "--lpips-weights " + (dir / "absent.dclpips").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("absent.dclpips: LPIPS weights file does not exist"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "map"));
}
