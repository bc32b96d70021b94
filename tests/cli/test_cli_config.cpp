// A configuration file changes only the keys it names: the preset `run` picks for the dataset stays
// (a file naming only the budget used to drop the outdoor preset on a street without a word).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli/cli_support.hpp"
#include "test_support.hpp"

using chungs::test::run_cli;

namespace {

nlohmann::json run_street(const std::filesystem::path& out, const std::string& extra) {
  auto r = run_cli("run --dataset synth-street:length=12,width=160,height=48,seed=2 --out " + out.string() +
                   " --iterations 1 --final-iterations 0 --device cpu --no-eval --json --quiet " + extra);
  EXPECT_EQ(r.code, 0) << r.out;
  const size_t brace = r.out.find('{');
  if (brace == std::string::npos) return {};
  return nlohmann::json::parse(r.out.substr(brace), nullptr, false);
}

}  // namespace

TEST(CliConfig, AFileNamingOneKeyKeepsTheDatasetsPreset) {
  chungs::test::TempDir dir;
  {
    std::ofstream f(dir / "budget.yaml");
    f << "residency:\n  budget_gaussians: 123456\n";
  }
  const nlohmann::json plain = run_street(dir / "plain", "");
  const nlohmann::json with_file = run_street(dir / "file", "--config " + (dir / "budget.yaml").string());
  ASSERT_TRUE(plain.contains("settings")) << plain.dump();
  ASSERT_TRUE(with_file.contains("settings")) << with_file.dump();
  EXPECT_EQ(with_file["settings"]["budget_gaussians"], 123456);
  // The outdoor preset's loss and learning rate, as without the file.
  EXPECT_EQ(with_file["settings"]["lambda_depth"], plain["settings"]["lambda_depth"]);
  EXPECT_EQ(with_file["settings"]["lr_position"], plain["settings"]["lr_position"]);
  // A named preset still applies under the file's keys.
  const nlohmann::json indoor =
      run_street(dir / "indoor", "--preset indoor --config " + (dir / "budget.yaml").string());
  ASSERT_TRUE(indoor.contains("settings"));
  EXPECT_NE(indoor["settings"]["lambda_depth"], plain["settings"]["lambda_depth"]);
  EXPECT_EQ(indoor["settings"]["budget_gaussians"], 123456);
}
