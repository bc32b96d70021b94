#include "chungs/synth/sequence.hpp"

#include <algorithm>
#include <chrono>
#include <future>

#include "chungs/common/log.hpp"
#include "chungs/common/progress.hpp"

namespace chungs::synth {

void render_frame(Rasterizer& r, Scene& scene, const Camera& cam, const SE3& T_wc, double baseline,
                  const RenderOptions& opt, RenderedFrame& out, RenderStats* stats) {
  ImageF rgb, unused_depth;
  const auto meshes = scene.gather(cam, T_wc, opt.far);
  r.render(meshes, cam, T_wc, scene.environment(), opt, rgb, out.depth, stats);
  out.left = to_u8(rgb);
  if (baseline > 0) {
    const SE3 T_right = T_wc * SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(baseline, 0, 0));
    const auto right_meshes = scene.gather(cam, T_right, opt.far);
    r.render(right_meshes, cam, T_right, scene.environment(), opt, rgb, unused_depth);
    out.right = to_u8(rgb);
  } else {
    out.right = Image8();
  }
}

SequenceReport render_sequence(Scene& scene, const Trajectory& traj, const Camera& cam, const SequenceOptions& opt,
                               const std::filesystem::path& out) {
  cam.validate("synthetic camera");
  if (cam.width > kMaxImageSide || cam.height > kMaxImageSide)
    fail("synthetic camera: image size ", cam.width, "x", cam.height, " exceeds ", kMaxImageSide,
         " pixels a side");
  // What the dataset readers take (image.hpp): a larger frame could not be read back, and its buffers
  // alone would take gigabytes.
  if (uint64_t(cam.width) * uint64_t(cam.height) > kMaxImagePixels)
    fail("synthetic camera: image size ", cam.width, "x", cam.height, " exceeds ", kMaxImagePixels,
         " pixels, the most a dataset image may have");
  if (traj.empty()) fail("synthetic sequence for ", out, ": the trajectory has no poses");
  if (traj.size() > kMaxFrames)
    fail("synthetic sequence for ", out, ": ", traj.size(), " frames, more than the ", kMaxFrames, " allowed");
  const bool stereo = opt.layout == Layout::Kitti;
  if (stereo && !(opt.baseline > 0)) fail("KITTI layout needs a positive stereo baseline, got ", opt.baseline);
  auto writer = opt.layout == Layout::Tum ? make_tum_writer(out, cam)
                                          : make_kitti_writer(out, cam, opt.baseline, opt.kitti_depth);
  SequenceReport rep;
  const auto t0 = std::chrono::steady_clock::now();
  Rasterizer rast;
  // Double buffering: frame i is encoded and written on a second thread while frame i+1 renders
  // (PNG compression would otherwise idle one of the cores).
  RenderedFrame frames[2];
  std::future<void> pending;
  Progress progress("rendering " + out.filename().string(), static_cast<long long>(traj.size()));
  for (size_t i = 0; i < traj.size(); ++i) {
    RenderedFrame& f = frames[i % 2];
    RenderStats stats;
    const auto r0 = std::chrono::steady_clock::now();
    render_frame(rast, scene, cam, traj.poses[i], stereo ? opt.baseline : 0, opt.render, f, &stats);
    rep.render_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - r0).count();
    rep.max_triangles_drawn = std::max(rep.max_triangles_drawn, stats.triangles_drawn);
    rep.max_scene_triangles = std::max(rep.max_scene_triangles, scene.triangles());
    if (pending.valid()) pending.get();  // rethrows a write error of the previous frame
    FrameOut fo;
    fo.index = i;
    fo.stamp = traj.stamps[i];
    fo.pose = traj.poses[i];
    fo.left = &f.left;
    fo.right = stereo ? &f.right : nullptr;
    fo.depth = &f.depth;
    pending = std::async(std::launch::async, [&writer, fo] { writer->add(fo); });
    progress.step();
  }
  if (pending.valid()) pending.get();
  writer->finish();
  progress.finish();
  rep.frames = traj.size();
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  log::info("wrote ", rep.frames, " frames (", layout_name(opt.layout), " layout) to ", out.string(), " in ",
            rep.seconds, " s (rendering ", rep.render_seconds, " s)");
  return rep;
}

}  // namespace chungs::synth
