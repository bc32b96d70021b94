#include "chungs/synth/street.hpp"

#include <algorithm>
#include <cmath>

#include "chungs/common/error.hpp"

namespace chungs::synth {

Camera kitti_camera(int width, int height) {
  const double f = 718.856 * width / 1241.0;
  return Camera(width, height, f, f, 0.5 * (width - 1), 0.5 * (height - 1));
}

StreetWorld::StreetWorld(const StreetOptions& opt, std::shared_ptr<StreetBlocks> blocks)
    : opt_(opt), env_(Environment::outdoor(uint32_t(opt.seed), opt.far)), blocks_(std::move(blocks)) {
  if (!(opt.pitch > opt.road_width + 2 * opt.sidewalk + 20))
    fail("street world: pitch ", opt.pitch, " m leaves no room for buildings (road ", opt.road_width, " m, sidewalks ",
         opt.sidewalk, " m)");
  if (opt.max_blocks < 16) fail("street world: max_blocks must be at least 16, got ", opt.max_blocks);
  if (!blocks_) blocks_ = std::make_shared<StreetBlocks>(opt);
}

const Mesh& StreetWorld::block(int bx, int by) { return *blocks_->get(bx, by); }

std::vector<const Mesh*> StreetWorld::gather(const Camera& cam, const SE3& T_wc, double far) {
  const double P = opt_.pitch, hw = 0.5 * opt_.road_width;
  const Eigen::Vector3d c = T_wc.t;
  const int x0 = int(std::floor((c.x() - far) / P)) - 1, x1 = int(std::floor((c.x() + far) / P)) + 1;
  const int y0 = int(std::floor((c.y() - far) / P)) - 1, y1 = int(std::floor((c.y() + far) / P)) + 1;
  std::vector<std::shared_ptr<const Mesh>> use;
  for (int by = y0; by <= y1; ++by) {
    for (int bx = x0; bx <= x1; ++bx) {
      // Conservative bounds of anything a block may hold (its own roads lie west and south).
      const Eigen::Vector3d lo(bx * P - hw - 1, by * P - hw - 1, -1), hi((bx + 1) * P + 1, (by + 1) * P + 1, 60);
      const double dx = std::max({lo.x() - c.x(), 0.0, c.x() - hi.x()}), dy = std::max({lo.y() - c.y(), 0.0, c.y() - hi.y()});
      if (dx * dx + dy * dy > far * far) continue;
      if (!box_maybe_visible(lo, hi, cam, T_wc, far)) continue;
      use.push_back(blocks_->get(bx, by));
    }
  }
  in_use_ = std::move(use);
  std::vector<const Mesh*> out;
  out.reserve(in_use_.size());
  for (const auto& m : in_use_) out.push_back(m.get());
  vehicles_.clear();
  if (traffic_) {
    for (const Vehicle& v : traffic_->vehicles) {
      Eigen::Vector2d centre, heading;
      if (!traffic_->place(v, time_, centre, heading)) continue;
      const double reach = 0.5 * v.length + 1;
      if ((centre - c.head<2>()).norm() > far + reach) continue;
      const Eigen::Vector3d lo(centre.x() - reach, centre.y() - reach, 0), hi(centre.x() + reach, centre.y() + reach, v.height);
      if (!box_maybe_visible(lo, hi, cam, T_wc, far)) continue;
      vehicles_.push_back(traffic_->mesh(v, time_));
      out.push_back(vehicles_.back().get());
    }
  }
  return out;
}

size_t StreetWorld::triangles() const { return blocks_->triangles(); }

}  // namespace chungs::synth
