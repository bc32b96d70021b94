// The timeline survives a checkpoint (JSON in run_state) and reads the shorter samples of maps saved
// before the I/O, VRAM and pacing columns existed; the CSV has one column per field, VRAM last.
#include "chungs/pipeline/timeline.hpp"

#include <gtest/gtest.h>

#include <random>
#include <sstream>

#include "chungs/common/error.hpp"

namespace chungs {
namespace {

TEST(Timeline, RoundTripsThroughJsonWithEveryField) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.5, 900.0);
  std::vector<TimelineSample> in(5);
  for (auto& t : in) {
    t.seconds = u(rng);
    t.frame = uint64_t(u(rng));
    t.keyframes = uint64_t(u(rng));
    t.iterations = uint64_t(u(rng)) * 30;
    t.resident = uint64_t(u(rng)) * 100;
    t.total = t.resident * 3;
    t.chunks = uint64_t(u(rng));
    t.rss_mb = u(rng);
    t.loads = uint64_t(u(rng));
    t.saves = uint64_t(u(rng));
    t.io_ms = u(rng);
    t.read_mb = u(rng);
    t.written_mb = u(rng);
    t.wait_ms = u(rng);
    t.disk_mb = u(rng);
    t.vram_mb = u(rng);
    t.sampled = uint64_t(u(rng)) * 1000;
    t.pruned = uint64_t(u(rng)) * 500;
    t.dropped = uint64_t(u(rng));
    t.checkpoint_ms = u(rng);
    t.path_m = u(rng);
  }
  const auto out = timeline_from_json(to_json(in));
  ASSERT_EQ(out.size(), in.size());
  for (size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(out[i].total, in[i].total);
    EXPECT_DOUBLE_EQ(out[i].io_ms, in[i].io_ms);
    EXPECT_DOUBLE_EQ(out[i].read_mb, in[i].read_mb);
    EXPECT_DOUBLE_EQ(out[i].written_mb, in[i].written_mb);
    EXPECT_DOUBLE_EQ(out[i].wait_ms, in[i].wait_ms);
    EXPECT_DOUBLE_EQ(out[i].disk_mb, in[i].disk_mb);
    EXPECT_DOUBLE_EQ(out[i].vram_mb, in[i].vram_mb);
    EXPECT_EQ(out[i].sampled, in[i].sampled);
    EXPECT_EQ(out[i].pruned, in[i].pruned);
    EXPECT_EQ(out[i].dropped, in[i].dropped);
    EXPECT_DOUBLE_EQ(out[i].checkpoint_ms, in[i].checkpoint_ms);
    EXPECT_DOUBLE_EQ(out[i].path_m, in[i].path_m);
  }
  std::istringstream csv(timeline_csv(in));
  std::string header, row;
  std::getline(csv, header);
  std::getline(csv, row);
  EXPECT_EQ(std::count(header.begin(), header.end(), ','), 20);
  EXPECT_EQ(std::count(row.begin(), row.end(), ','), 20);
  EXPECT_NE(header.find("dropped_keyframes"), std::string::npos);
  EXPECT_NE(header.find("io_wait_ms"), std::string::npos);
  // A GPU test and scripts find VRAM as the last column.
  const std::string last = ",vram_used_mb";
  EXPECT_EQ(header.substr(header.size() - last.size()), last);
  EXPECT_NEAR(std::stod(row.substr(row.rfind(',') + 1)), in[0].vram_mb, 1e-5 * in[0].vram_mb);  // 6 digits
}

TEST(Timeline, ReadsOlderElevenFifteenAndSixteenFieldSamplesAndRejectsOthers) {
  const nlohmann::json old = nlohmann::json::parse("[[1.5, 3, 2, 60, 100, 200, 4, 50.0, 1, 2, 3.5]]");
  const auto t = timeline_from_json(old);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].total, 200u);
  EXPECT_EQ(t[0].disk_mb, 0.0);
  EXPECT_EQ(t[0].vram_mb, 0.0);
  const auto v = timeline_from_json(
      nlohmann::json::parse("[[1.5, 3, 2, 60, 100, 200, 4, 50.0, 1, 2, 3.5, 7.0, 8.0, 9.5, 123.25]]"));
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v[0].disk_mb, 123.25);
  EXPECT_EQ(v[0].vram_mb, 0.0);
  const auto w = timeline_from_json(
      nlohmann::json::parse("[[1.5, 3, 2, 60, 100, 200, 4, 50.0, 1, 2, 3.5, 7.0, 8.0, 9.5, 123.25, 640.5]]"));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].vram_mb, 640.5);
  EXPECT_EQ(w[0].sampled, 0u);
  EXPECT_EQ(w[0].path_m, 0.0);
  EXPECT_THROW(timeline_from_json(nlohmann::json::parse("[[1, 2, 3]]")), Error);
}

}  // namespace
}  // namespace chungs
