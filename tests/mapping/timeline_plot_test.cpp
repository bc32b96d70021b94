// The memory plot shows every curve over its whole range: nothing (legend, other curves) hides one.
#include <gtest/gtest.h>

#include "chungs/image/image_io.hpp"
#include "chungs/mapping/timeline.hpp"
#include "test_support.hpp"

namespace chungs {

TEST(TimelinePlot, EveryCurveIsVisibleAcrossThePlot) {
  test::TempDir dir;
  std::vector<TimelineSample> s;
  for (uint64_t k = 1; k <= 100; ++k) {
    TimelineSample t;
    t.keyframes = k;
    t.total = 1000 * k;
    t.resident = std::min<uint64_t>(t.total, 60000);
    t.rss_mb = 58;  // flat near the top of its axis, where a legend inside the plot would sit
    s.push_back(t);
  }
  write_timeline_plot(dir / "m.png", s, 60000);
  const Image8 img = read_image8(dir / "m.png");
  auto column_has = [&](int x, int r, int g, int b) {
    for (int y = 45; y < img.height() - 50; ++y)
      if (std::abs(img(x, y, 0) - r) < 30 && std::abs(img(x, y, 1) - g) < 30 && std::abs(img(x, y, 2) - b) < 30)
        return true;
    return false;
  };
  int missing_rss = 0, missing_resident = 0;
  // Plot columns from the first to the last sample (x axis ends at 100 keyframes here).
  for (int x = 90; x < img.width() - 90; x += 7) {
    missing_rss += !column_has(x, 20, 150, 60);
    missing_resident += !column_has(x, 220, 40, 40);
  }
  EXPECT_EQ(missing_rss, 0);
  EXPECT_EQ(missing_resident, 0);
}

}  // namespace chungs
