// Mapper::redepth: a keyframe's guessed depths replaced by a later sweep's (one camera, issue 25).
#include <cmath>

#include "chungs/common/log.hpp"
#include "chungs/mapping/mapper.hpp"

namespace chungs {

size_t Mapper::redepth(uint64_t frame, const ImageF& fresh) {
  KeyframeRecord* kf = &keyframe_of_frame(frame);
  const std::shared_ptr<const KeyframeImages> images = keyframe_store_->get(kf->id);
  const ImageF& old = images->depth;
  if (fresh.width() != images->color.width() || fresh.height() != images->color.height() || fresh.channels() != 1)
    fail("mapper: frame ", frame, ": depth ", fresh.width(), "x", fresh.height(), "x", fresh.channels(),
         " does not match the image ", images->color.width(), "x", images->color.height());
  if (old.empty()) return 0;  // sampled from a depth it does not keep (the first keyframe)
  const auto replaces = [&](float before, float now) { return before < 0 && now > 0 && std::isfinite(now); };
  ImageF updated = old;
  size_t replaced = 0;
  for (size_t i = 0; i < old.vec().size(); ++i)
    if (replaces(old.vec()[i], fresh.vec()[i])) updated.vec()[i] = fresh.vec()[i], ++replaced;
  if (replaced == 0) return 0;

  const uint32_t id = kf->id;
  const Camera& cam = kf->camera;
  const SE3 T_cw = kf->pose.inverse();
  const Eigen::Vector3d centre = kf->pose.t;
  PoseCorrection pc;
  pc.allow_batch = loop_batch_allowed_;
  pc.reshape = [&](GaussianBlock& b, size_t i) {
    if (b.created_by_keyframe[i] != id) return false;
    float* m = &b.params.mean[3 * i];
    const Eigen::Vector3d world(m[0], m[1], m[2]);
    const Eigen::Vector3d p = T_cw * world;
    if (!(p.z() > 0) || !p.allFinite()) return false;
    const Eigen::Vector2d px = cam.project(p);
    const long x = std::lround(px.x()), y = std::lround(px.y());
    if (x < 0 || y < 0 || x >= old.width() || y >= old.height()) return false;
    const float before = old(int(x), int(y)), now = fresh(int(x), int(y));
    if (!replaces(before, now)) return false;
    // One the optimiser has carried off its guess found a place of its own.
    if (std::abs(p.z() + double(before)) > 0.25 * -double(before)) return false;
    const double k = double(now) / p.z();
    const Eigen::Vector3d moved = centre + k * (world - centre);
    const float log_k = float(std::log(k));
    for (int a = 0; a < 3; ++a) m[a] = float(moved[a]), b.params.log_scale[3 * i + a] += log_k;
    return true;
  };
  PoseCorrectionStats st;
  if (keyframe_chunks_.complete()) {
    const std::vector<uint32_t> ids{id};
    st = apply_pose_correction(*residency_, store_->chunk_size(), pc, keyframe_chunks_.chunks_of(ids),
                               keyframe_chunks_);
    if (st.gaussians_changed_chunk > 0) {
      view_chunks_.clear();  // Gaussians entered chunks the cached views may not list
      coverage_.clear();
    }
  }
  keyframe_store_->put(id, KeyframeImages{images->color, std::move(updated)});
  ++kf->depth_version;  // a backend's cached copy of the old depth is not used again
  redepth_totals_.keyframes += 1;
  redepth_totals_.pixels += replaced;
  redepth_totals_.gaussians_moved += st.gaussians_moved;
  log::debug("frame ", frame, ": ", replaced, " guessed depths replaced by later ones, ", st.gaussians_moved,
             " Gaussians moved to them");
  return replaced;
}

}  // namespace chungs
