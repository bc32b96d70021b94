// `diskchungs pareto` on a tiny street: every point is mapped into its own folder and scored, the
// table, JSON and plot hold them all, a second invocation reads the finished points instead of
// mapping them again (and maps only points it has not seen), a point made with other settings is
// refused, and bad lists are one error naming the flag with nothing written.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "chungs/eval/lpips_weights.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/pipeline/pareto_plot.hpp"
#include "cli/cli_support.hpp"
#include "eval/lpips_fixtures.hpp"
#include "test_support.hpp"

using chungs::test::read_all;
using chungs::test::run_cli;
namespace fs = std::filesystem;

namespace {

const std::string kTiny =
    "-q pareto --dataset synth-street:length=30,width=160,height=48,seed=2 --device cpu --max-frames 12";


size_t occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

int pixels_of(const chungs::Image8& img, const chungs::PlotRgb& c) {
  int n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) n += img(x, y, 0) == c[0] && img(x, y, 1) == c[1] && img(x, y, 2) == c[2];
  return n;
}

}  // namespace

TEST(CliPareto, MapsEveryPointWritesTableAndPlotAndReusesFinishedPoints) {
  chungs::test::TempDir dir;
  const fs::path out = dir / "pareto";
  const std::string args = kTiny + " --iterations 2,5 --speeds 4 --out " + out.string();
  auto r = run_cli(args);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("point 1/3: fixed 2 steps per keyframe -> " + (out / "fixed-2").string()), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("point 3/3: anytime 4x speed -> " + (out / "anytime-4").string()), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("LPIPS: not available"), std::string::npos) << r.out;

  const auto j = nlohmann::json::parse(read_all(out / "pareto.json"));
  ASSERT_EQ(j["points"].size(), 3u) << j.dump(2);
  const char* modes[] = {"fixed", "fixed", "anytime"};
  for (size_t i = 0; i < 3; ++i) {
    const auto& p = j["points"][i];
    EXPECT_EQ(p["mode"], modes[i]);
    EXPECT_TRUE(fs::exists(out / p["folder"].get<std::string>() / "report.json"));
    EXPECT_GT(p["processing_fps"].get<double>(), 0);
    EXPECT_GT(p["mapping_s"].get<double>(), 0);
    EXPECT_GT(p["gaussians"].get<double>(), 0);
    for (const char* set : {"held_out", "keyframes_eval"}) {
      const double psnr = p[set]["psnr"].get<double>(), ssim = p[set]["ssim"].get<double>();
      EXPECT_TRUE(std::isfinite(psnr) && psnr > 5) << set << " " << p.dump();
      EXPECT_TRUE(ssim > 0 && ssim <= 1) << set << " " << p.dump();
      // No weights: no LPIPS number, and the reason in its place.
      EXPECT_TRUE(p[set]["lpips"].is_null()) << p.dump();
      EXPECT_TRUE(p[set]["lpips_unavailable"].is_string()) << p.dump();
    }
  }
  // Fixed pacing gives every keyframe the steps asked for.
  EXPECT_EQ(j["points"][0]["setting"], 2);
  EXPECT_DOUBLE_EQ(j["points"][0]["steps_per_keyframe_mean"].get<double>(), 2);
  EXPECT_DOUBLE_EQ(j["points"][1]["steps_per_keyframe_mean"].get<double>(), 5);
  EXPECT_EQ(j["points"][2]["setting"], 4.0);

  const std::string csv = read_all(out / "pareto.csv");
  EXPECT_EQ(occurrences(csv, "\n"), 4u) << csv;
  EXPECT_EQ(csv.rfind("mode,setting,processing_fps,", 0), 0u) << csv;
  EXPECT_NE(csv.find("\nfixed,2,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nanytime,4,"), std::string::npos) << csv;

  const chungs::Image8 png = chungs::read_image8(out / "pareto.png");
  EXPECT_EQ(png.width(), chungs::kParetoPlotWidth);
  EXPECT_EQ(png.height(), chungs::kParetoPlotHeight);
  // Both curves drawn: two fixed points joined by lines in three panels, the anytime one marked.
  EXPECT_GT(pixels_of(png, chungs::kParetoFixed), 500);
  EXPECT_GT(pixels_of(png, chungs::kParetoAnytime), 100);

  // Again: all three read, none mapped, the table the same.
  const std::string report = read_all(out / "fixed-2/report.json");
  r = run_cli(args);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(occurrences(r.out, "finished earlier, read from"), 3u) << r.out;
  EXPECT_EQ(occurrences(r.out, " -> "), 0u) << r.out;
  EXPECT_EQ(read_all(out / "fixed-2/report.json"), report);
  EXPECT_EQ(nlohmann::json::parse(read_all(out / "pareto.json")), j);

  // One more point: only it is mapped.
  r = run_cli(kTiny + " --iterations 2,5,8 --speeds 4 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(occurrences(r.out, "finished earlier, read from"), 3u) << r.out;
  EXPECT_NE(r.out.find("point 3/4: fixed 8 steps per keyframe -> "), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(read_all(out / "pareto.json"))["points"].size(), 4u);

  // A finished point made with another budget is not mixed in: refused, naming the setting.
  const std::string before = read_all(out / "pareto.json");
  r = run_cli(kTiny + " --iterations 2 --speeds none --budget 5000 --out " + out.string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("fixed-2/report.json: the point was mapped with budget"), std::string::npos) << r.out;
  EXPECT_EQ(read_all(out / "pareto.json"), before);
}

TEST(CliPareto, WithLpipsWeightsEveryPointHasLpips) {
  chungs::test::TempDir dir;
  chungs::write_lpips_weights(dir / "w.dclpips", chungs::test::random_lpips_weights(5));
  const fs::path out = dir / "pareto";
  auto r = run_cli(kTiny + " --iterations 3 --speeds none --lpips-weights " + (dir / "w.dclpips").string() +
                   " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto j = nlohmann::json::parse(read_all(out / "pareto.json"));
  ASSERT_EQ(j["points"].size(), 1u);
  for (const char* set : {"held_out", "keyframes_eval"}) {
    ASSERT_TRUE(j["points"][0][set]["lpips"].is_number()) << j.dump(2);
    EXPECT_GE(j["points"][0][set]["lpips"].get<double>(), 0);
    EXPECT_FALSE(j["points"][0][set].contains("lpips_unavailable"));
  }
  EXPECT_EQ(r.out.find("not available"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out / "anytime-1"));
}

TEST(CliPareto, BadListsAreOneErrorNamingTheFlagAndNothingIsWritten) {
  const std::pair<std::string, std::string> cases[] = {
      {"--iterations 10,abc", "--iterations entries must be whole numbers of steps, 0 or more, got 'abc'"},
      {"--iterations -3", "got '-3'"},
      {"--iterations 2.5", "got '2.5'"},
      {"--iterations ''", "--iterations must list at least one value"},
      {"--iterations 5,,6", "--iterations has an empty entry in '5,,6'"},
      {"--iterations 10,010", "--iterations lists fixed 10 steps per keyframe twice"},
      {"--speeds 0", "--speeds entries must be factors from 0.01 to 1000, got '0'"},
      {"--speeds 1e-320", "--speeds entries must be factors from 0.01 to 1000, got '1e-320'"},
      {"--speeds inf", "got 'inf'"},
      {"--speeds 1e308", "--speeds entries must be factors from 0.01 to 1000, got '1e308'"},  // was inf km/h
      {"--speeds 1,x", "got 'x'"},
      {"--speeds 1,1.0", "--speeds lists anytime 1x speed twice"},
      {"--speeds ''", "--speeds must list at least one value"},
      {"--iterations none --speeds none", "there is no point to map"},
      {"--resolution 0", "--resolution must be in (0, 1]"},
      {"--final-iterations -1", "--final-iterations must be 0 or more"},
      {"--lpips-weights /nonexistent/w.dclpips", "/nonexistent/w.dclpips"},
  };
  for (const auto& [flag, message] : cases) {
    chungs::test::TempDir dir;
    const fs::path out = dir / "pareto";
    auto r = run_cli(kTiny + " " + flag + " --out " + out.string());
    EXPECT_NE(r.code, 0) << flag << ": " << r.out;
    EXPECT_NE(r.out.find(message), std::string::npos) << flag << ": " << r.out;
    EXPECT_EQ(occurrences(r.out, "\n"), 1u) << flag << ": " << r.out;
    EXPECT_FALSE(fs::exists(out)) << flag;
  }
}
