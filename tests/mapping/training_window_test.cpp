// The training window: the keyframes nearest the latest whose chunks fit the room together.
#include <gtest/gtest.h>

#include <map>

#include "chungs/mapping/training_window.hpp"

namespace chungs {
namespace {

TEST(TrainingWindow, TakesTheNearestKeyframesWhoseChunksFitTogether) {
  // Keyframes along a street, each seeing its own chunk and the next two; chunk c holds 100 + c.
  std::map<uint32_t, std::vector<ChunkId>> views;
  for (uint32_t k = 0; k < 10; ++k) views[k] = {k, k + 1, k + 2};
  auto count = [](ChunkId c) { return uint64_t(100 + c); };
  std::vector<WindowKeyframe> kfs;
  for (uint32_t k = 0; k < 10; ++k) kfs.push_back({k, 9.0 - k, &views[k]});  // 9 is the latest
  // Chunks 9..11 (330), then 8 (+108), 7 (+107), 6 (+106): 651 fit 660, 5 (+105) does not.
  EXPECT_EQ(fit_training_window(kfs, count, 660), (std::vector<uint32_t>{9, 8, 7, 6}));
  EXPECT_EQ(fit_training_window(kfs, count, 1e9).size(), 10u);
  // The latest keyframe stays even when its own view alone is over the room.
  EXPECT_EQ(fit_training_window(kfs, count, 10), (std::vector<uint32_t>{9}));
}

TEST(TrainingWindow, SharedChunksAreCountedOnceAndTheWindowStaysABall) {
  std::vector<ChunkId> shared = {1, 2}, far = {50}, near = {1, 3};
  auto count = [](ChunkId c) { return c == 50 ? uint64_t(1000) : uint64_t(10); };
  std::vector<WindowKeyframe> kfs = {{7, 0, &shared}, {3, 2, &near}, {5, 1, &shared}, {1, 5, &far}, {2, 9, &near}};
  // 7 (20), 5 (shares: +0), 3 (+10): 30; 1 needs 1000 more, so 2 (which would fit) stays out too.
  EXPECT_EQ(fit_training_window(kfs, count, 100), (std::vector<uint32_t>{7, 5, 3}));
}

}  // namespace
}  // namespace chungs
