// Revisits (selector.revisit_share): a share of the steps trains keyframes far behind the latest one, in
// bursts on keyframes near one drawn at random, so that places keep being trained from the views that saw
// them after the car has passed (issue 19).
#include <gtest/gtest.h>

#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"
#include "synthetic_sequence.hpp"
#include "test_support.hpp"
#include "tiny_config.hpp"

namespace chungs {
namespace {

TEST(MapperRevisits, AShareOfTheStepsTrainsKeyframesFarBehindInBursts) {
  log::set_level(log::Level::Error);
  for (double share : {0.5, 0.0}) {
    test::TempDir dir;
    Config c = test::tiny_mapping_config();
    c.mapper.device = "cpu";
    c.selector.cell_size = 6;  // revisits reach 3 m back
    c.selector.revisit_share = share;
    c.selector.revisit_burst = 4;
    c.selector.revisit_min_distance = 1.0;
    c.selector.revisit_group_m = 0.3;
    const test::WallSequence seq(30);  // 8 cm apart: 2.3 m of keyframes
    Mapper m(dir / "map", c, false);
    for (size_t i = 0; i < 30; ++i) {
      const Frame f = seq.frame(i);
      m.add_keyframe(i, f.timestamp, f.left, f.depth, f.camera, *f.gt_pose);
    }
    const Eigen::Vector3d latest = m.keyframes().back().pose.t;
    auto where = [&](uint32_t id) {
      for (const KeyframeRecord& k : m.keyframes())
        if (k.id == id) return k.pose.t;
      ADD_FAILURE() << "no keyframe " << id;
      return Eigen::Vector3d(Eigen::Vector3d::Zero());
    };
    const int steps = 80;
    int revisits = 0;
    std::vector<Eigen::Vector3d> run;  // positions of the current run of revisit steps
    for (int s = 0; s < steps; ++s) {
      const StepStats st = m.step();
      if (!st.revisit) {
        run.clear();
        continue;
      }
      ++revisits;
      const Eigen::Vector3d p = where(st.keyframe);
      const double behind = (p - latest).norm();
      EXPECT_GT(behind, 1.0) << "step " << s << " revisited keyframe " << st.keyframe << " only " << behind
                             << " m back";
      EXPECT_LE(behind, 3.0) << "step " << s << ": beyond half the cell";
      for (const Eigen::Vector3d& q : run)
        EXPECT_LE((p - q).norm(), 0.6 + 1e-9) << "a burst stays near the keyframe it was drawn around";
      if (run.size() == 4) run.clear();  // bursts of 4 may follow each other
      run.push_back(p);
    }
    EXPECT_EQ(uint64_t(revisits), m.window_stats().revisit_steps);
    if (share > 0) {
      // One burst of 4 per 8 picks; the picks drawn ahead shift the count by at most a burst.
      EXPECT_GE(revisits, steps / 2 - 8);
      EXPECT_LE(revisits, steps / 2 + 8);
      EXPECT_GE(m.window_stats().revisit_bursts, uint64_t(steps / 8 - 2));
    } else {
      EXPECT_EQ(revisits, 0);
      EXPECT_EQ(m.window_stats().revisit_bursts, 0u);
    }
  }
}

TEST(MapperRevisits, OutOfRangeSettingsAreRefused) {
  for (auto set : std::vector<void (*)(KeyframeSelectorConfig&)>{
           [](KeyframeSelectorConfig& s) { s.revisit_share = 1.0; },
           [](KeyframeSelectorConfig& s) { s.revisit_share = -0.1; },
           [](KeyframeSelectorConfig& s) { s.revisit_burst = 0; },
           [](KeyframeSelectorConfig& s) { s.revisit_min_distance = std::nan(""); },
           [](KeyframeSelectorConfig& s) { s.revisit_group_m = -1; }}) {
    KeyframeSelectorConfig s;
    set(s);
    EXPECT_THROW(s.validate(), Error);
  }
  KeyframeSelectorConfig ok;
  ok.revisit_share = 0.5;
  EXPECT_NO_THROW(ok.validate());
}

}  // namespace
}  // namespace chungs
