// A tiny in-memory RGB-D sequence for mapping tests: a camera slides sideways along a textured wall
// (plane z = wall_z, normal towards the camera), with exact colour and depth rendered analytically.
#pragma once
#include <cmath>

#include "chungs/datasets/dataset.hpp"

namespace chungs::test {

class WallSequence : public Dataset {
 public:
  WallSequence(size_t frames, int width = 64, int height = 48, double step = 0.08, double wall_z = 3.0)
      : step_(step), wall_z_(wall_z) {
    info_.kind = "synthetic";
    info_.path = "wall";
    info_.frames = frames;
    info_.camera = Camera(width, height, 50.0, 50.0, (width - 1) / 2.0, (height - 1) / 2.0);
    info_.has_depth = info_.has_gt = info_.color = true;
    info_.rate_hz = 10;
  }
  const DatasetInfo& info() const override { return info_; }
  double timestamp(size_t i) const override { return 0.1 * double(i); }
  std::optional<SE3> gt_pose(size_t i) const override {
    return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(step_ * double(i), 0.02 * std::sin(0.5 * double(i)), 0));
  }
  Frame frame(size_t i) const override {
    if (i >= info_.frames) fail("wall sequence: no frame ", i);
    Frame f;
    f.index = i;
    f.timestamp = timestamp(i);
    f.camera = info_.camera;
    f.gt_pose = gt_pose(i);
    const Camera& c = info_.camera;
    f.left = Image8(c.width, c.height, 3);
    ImageF depth(c.width, c.height, 1);
    for (int y = 0; y < c.height; ++y)
      for (int x = 0; x < c.width; ++x) {
        // Ray through the pixel hits the wall at depth wall_z (the camera never rotates).
        const double wx = (x - c.cx) / c.fx * wall_z_ + f.gt_pose->t.x(), wy = (y - c.cy) / c.fy * wall_z_ + f.gt_pose->t.y();
        depth(x, y) = float(wall_z_);
        const double a = 0.5 + 0.35 * std::sin(7 * wx) * std::cos(5 * wy), b = 0.5 + 0.4 * std::sin(11 * wx + 3 * wy),
                     checker = (int(std::floor(wx * 4)) + int(std::floor(wy * 4))) % 2 ? 0.2 : 0.8;
        f.left(x, y, 0) = uint8_t(std::lround(255 * a));
        f.left(x, y, 1) = uint8_t(std::lround(255 * b));
        f.left(x, y, 2) = uint8_t(std::lround(255 * (0.3 * a + 0.7 * checker)));
      }
    f.depth = depth;
    f.source = "wall frame " + std::to_string(i);
    return f;
  }

 private:
  DatasetInfo info_;
  double step_, wall_z_;
};

}  // namespace chungs::test
