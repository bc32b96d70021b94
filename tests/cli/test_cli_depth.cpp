// `eval depth`: AbsRel and delta < 1.25 of a folder of depth PNGs against ground truth, as text and
// JSON, with each PNG's units per metre; bad scales and unpaired files are one error line.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <cmath>
#include <random>

#include "chungs/image/image_io.hpp"
#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;

namespace {

chungs::Image16 depth_png(int w, int h, std::mt19937& rng, double scale, double factor) {
  std::uniform_real_distribution<double> U(1.0, 10.0);
  chungs::Image16 out(w, h, 1);
  for (auto& v : out.vec()) v = uint16_t(std::lround(U(rng) * factor * scale));
  return out;
}

}  // namespace

TEST(CliDepth, ScoresFoldersWithTheirScalesAsTextAndJson) {
  chungs::test::TempDir dir;
  std::mt19937 a(4), b(4);  // one stream of depths: the estimate is the truth x 1.2
  chungs::write_png(dir / "gt/000000.png", depth_png(30, 20, a, 5000, 1.0));
  chungs::write_png(dir / "est/000000.png", depth_png(30, 20, b, 1000, 1.2));
  const std::string args = "eval depth --gt " + (dir / "gt").string() + " --est " + (dir / "est").string();
  auto r = run_cli("-q " + args + " --est-scale 1000 --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j["pooled"]["abs_rel"].get<double>(), 0.2, 2e-3);
  EXPECT_EQ(j["pooled"]["delta1"].get<double>(), 1.0);
  EXPECT_EQ(j["pooled"]["pixels"].get<size_t>(), 600u);
  r = run_cli("-q " + args + " --est-scale 1000");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("AbsRel 0.2"), std::string::npos) << r.out;
  // The default scale (5000) on the millimetre file: the figure changes, so the flag is applied.
  r = run_cli("-q " + args + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_GT(nlohmann::json::parse(r.out)["pooled"]["abs_rel"].get<double>(), 0.7);
}

TEST(CliDepth, BadScaleOrUnpairedFilesAreOneErrorLine) {
  chungs::test::TempDir dir;
  std::mt19937 rng(5);
  chungs::write_png(dir / "gt/a.png", depth_png(8, 8, rng, 5000, 1.0));
  chungs::write_png(dir / "est/b.png", depth_png(8, 8, rng, 5000, 1.0));
  const std::string args = "eval depth --gt " + (dir / "gt").string() + " --est " + (dir / "est").string();
  auto r = run_cli(args + " --gt-scale 0");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("--gt-scale"), std::string::npos) << r.out;
  r = run_cli(args);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("missing"), std::string::npos) << r.out;
  chungs::write_png(dir / "est/a.png", chungs::Image8(8, 8, 3, 1));  // colour, not depth
  std::filesystem::remove(dir / "est/b.png");
  r = run_cli(args);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("a.png"), std::string::npos) << r.out;
}
