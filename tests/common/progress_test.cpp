#include "chungs/common/progress.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <thread>

#include "chungs/common/log.hpp"

namespace chungs {
namespace {

size_t lines(const std::string& s) { return size_t(std::count(s.begin(), s.end(), '\n')); }

struct InfoLevel {
  log::Level was = log::level();
  InfoLevel() { log::set_level(log::Level::Info); }
  ~InfoLevel() { log::set_level(was); }
};

}  // namespace

// ctest's stderr is a pipe, so these exercise the log form (a line per tenth, and between tenths after
// a quiet gap); a terminal would redraw one line instead.
TEST(Progress, LogFormPrintsEachTenthOnceAndTheEnd) {
  InfoLevel info;
  testing::internal::CaptureStderr();
  {
    Progress p("work", 1000);
    for (int i = 0; i < 1000; ++i) p.step();
  }
  const std::string out = testing::internal::GetCapturedStderr();
  EXPECT_EQ(lines(out), 11u) << out;  // the first step (0 %), 10 %, ..., 100 %; finish() repeats nothing
  EXPECT_NE(out.find("work: 100/1000 (10%)"), std::string::npos) << out;
  EXPECT_NE(out.find(", eta "), std::string::npos) << out;
  EXPECT_NE(out.find("work: 1000/1000 (100%)"), std::string::npos) << out;
}

// A tenth of a million refinement steps can take hours: the log must not go silent that long.
TEST(Progress, LogFormSpeaksWithinAQuietGapBetweenTenths) {
  InfoLevel info;
  testing::internal::CaptureStderr();
  {
    Progress p("refining", 1000000, std::chrono::milliseconds(20));
    for (int i = 0; i < 4; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
      p.step();
    }
    p.finish();
  }
  const std::string out = testing::internal::GetCapturedStderr();
  // Every step came after a quiet gap, so each printed: steps 1-4 (0 %), all within the first tenth.
  EXPECT_GE(lines(out), 4u) << out;
  EXPECT_NE(out.find("refining: 4/1000000 (0%)"), std::string::npos) << out;
  // Four steps of a million in 0.12 s tell nothing of the time left.
  EXPECT_EQ(out.find("eta"), std::string::npos) << out;
}

TEST(Progress, QuietLevelPrintsNothing) {
  InfoLevel info;
  log::set_level(log::Level::Warn);
  testing::internal::CaptureStderr();
  {
    Progress p("work", 10, std::chrono::milliseconds(0));
    for (int i = 0; i < 10; ++i) p.step();
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

}  // namespace chungs
