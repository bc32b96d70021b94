// The mapper's optimisation backends: the CUDA backend maps a tiny synthetic sequence to the same
// quality as the CPU one (it computes the same function; float summation order differs, and the
// sampler sees slightly different renders, so the maps are close, not identical), reports VRAM over
// time, and asking for cuda where it cannot run is one clear error. GPU tests skip without a GPU.
#include <gtest/gtest.h>

#include <fstream>

#include "chungs/common/log.hpp"
#include "chungs/mapping/optim_backend.hpp"
#include "chungs/pipeline/run_pipeline.hpp"
#include "mapping/synthetic_sequence.hpp"
#include "test_support.hpp"
#include "mapping/tiny_config.hpp"

namespace chungs {
namespace {

Config tiny_gpu_config(const std::string& device) {
  Config c = test::tiny_mapping_config();
  c.mapper.checkpoint_every = 4;
  c.mapper.device = device;
  return c;
}

nlohmann::json run_on(const std::string& device, const std::filesystem::path& out, const Dataset& seq) {
  RunOptions o;
  o.dataset = "synthetic:wall";
  o.out = out;
  o.config = tiny_gpu_config(device);
  return run_mapping(o, seq);
}

TEST(MappingDevice, UnknownDeviceNamesAreRefused) {
  EXPECT_THROW(resolve_device("gpu"), Error);
  EXPECT_EQ(resolve_device("cpu"), "cpu");
  const std::string a = resolve_device("auto");
  EXPECT_TRUE(a == "cpu" || a == "cuda") << a;
}

TEST(MappingDevice, CudaWhereItCannotRunIsOneClearError) {
  if (resolve_device("auto") == "cuda") GTEST_SKIP() << "a usable GPU is present";
  try {
    resolve_device("cuda");
    FAIL() << "device cuda was accepted without a usable GPU";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("--device cpu"), std::string::npos) << m;
  }
}

TEST(CudaMapping, TinyRunMatchesTheCpuBackend) {
  if (resolve_device("auto") != "cuda") GTEST_SKIP() << "no usable GPU (or no CUDA build)";
  log::set_level(log::Level::Warn);
  test::TempDir dir;
  const test::WallSequence seq(16);
  const auto rc = run_on("cpu", dir / "cpu", seq);
  const auto rg = run_on("cuda", dir / "cuda", seq);
  const double pc = rc["held_out"]["mean_psnr"], pg = rg["held_out"]["mean_psnr"];
  const double sc = rc["held_out"]["mean_ssim"], sg = rg["held_out"]["mean_ssim"];
  std::printf(
      "held-out PSNR cpu %.3f dB, cuda %.3f dB; SSIM cpu %.4f, cuda %.4f; Gaussians cpu %llu, cuda %llu\n",
      pc, pg, sc, sg, (unsigned long long)rc["gaussians"]["total"].get<uint64_t>(),
      (unsigned long long)rg["gaussians"]["total"].get<uint64_t>());
  EXPECT_EQ(rc["device"], "cpu");
  EXPECT_EQ(rg["device"], "cuda");
  EXPECT_GT(pc, 20.0);  // both actually trained
  EXPECT_NEAR(pg, pc, 0.5);
  EXPECT_NEAR(sg, sc, 0.02);
  // VRAM is in the report and, per keyframe, in the timeline.
  ASSERT_TRUE(rg["memory"].contains("vram_used_mb_peak_sampled"));
  EXPECT_GT(rg["memory"]["vram_used_mb_peak_sampled"].get<double>(), 0.0);
  EXPECT_FALSE(rc["memory"].contains("vram_used_mb_peak_sampled"));
  std::ifstream csv(dir / "cuda" / "timeline.csv");
  std::string header, row;
  std::getline(csv, header);
  std::getline(csv, row);
  EXPECT_NE(header.find(",vram_used_mb"), std::string::npos) << header;
  EXPECT_GT(std::stod(row.substr(row.rfind(',') + 1)), 0.0) << row;
}

}  // namespace
}  // namespace chungs
