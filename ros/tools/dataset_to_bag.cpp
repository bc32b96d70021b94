// chungs_dataset_to_bag KIND:PATH OUT.bag [--max-frames N]
// Writes a dataset as a robot would record it, so the rosbag: reader and the node can be tested
// against the same frames read directly: stereo pairs (or colour + registered depth) with
// camera_info, and the ground truth as tf: world -> base_link per frame, with the cameras' optical
// frames on a static, deliberately non-trivial mount (x forward body, z forward optical), so a
// reader has to chain transforms to get the camera's pose right. The body's pose is also written as a
// nav_msgs/Odometry topic (/odometry) for the node's odometry pose source.
#include <cstdlib>
#include <iostream>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/datasets/dataset.hpp"
#include "chungs/datasets/rosbag_io.hpp"

using namespace chungs;
namespace rb = chungs::rosbag_io;

namespace {

rb::Pose to_pose(const SE3& p) { return {{p.t.x(), p.t.y(), p.t.z()}, {p.q.x(), p.q.y(), p.q.z(), p.q.w()}}; }

// base_link (x forward, y left, z up) <- optical (x right, y down, z forward), 1.6 m above the base.
SE3 camera_mount() {
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return SE3(r, Eigen::Vector3d(0.3, 0.1, 1.6));
}

rb::CameraInfo camera_info(const Camera& c, double baseline, const std::string& frame) {
  rb::CameraInfo info;
  info.frame_id = frame;
  info.width = c.width;
  info.height = c.height;
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {c.fx, 0, c.cx, -c.fx * baseline, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  return info;
}

rb::Picture picture(const Image8& img) {
  rb::Picture p;
  p.width = img.width();
  p.height = img.height();
  p.channels = img.channels();
  p.pixels = img.vec();
  return p;
}

rb::Picture picture(const ImageF& depth) {
  rb::Picture p;
  p.width = depth.width();
  p.height = depth.height();
  p.channels = 1;
  p.metres = depth.vec();
  return p;
}

int convert(int argc, char** argv) {
  if (argc < 3) fail("usage: chungs_dataset_to_bag KIND:PATH OUT.bag [--max-frames N]");
  size_t max_frames = 0;
  for (int a = 3; a < argc; ++a) {
    std::string arg = argv[a];
    if (arg == "--max-frames" && a + 1 < argc) {
      max_frames = size_t(std::stoul(argv[++a]));
    } else {
      fail("chungs_dataset_to_bag: unknown argument '", arg, "'");
    }
  }
  auto dataset = open_dataset(argv[1]);
  const auto& in = dataset->info();
  const size_t n = max_frames ? std::min(max_frames, dataset->size()) : dataset->size();
  // ros::Time(0) means "the latest" to tf: keep every stamp well clear of zero.
  const double offset = dataset->timestamp(0) < 1 ? 1000.0 : 0.0;
  const SE3 mount = camera_mount();
  const bool rgbd = in.has_depth && !in.has_right;
  const std::string left_frame = rgbd ? "camera_color_optical" : "camera_left_optical";
  const std::string left_topic = rgbd ? "/camera/color/image_raw" : "/stereo/left/image_rect";
  const std::string left_info = rgbd ? "/camera/color/camera_info" : "/stereo/left/camera_info";

  rb::BagWriter bag(argv[2]);
  bag.transform(offset + dataset->timestamp(0), "base_link", left_frame, to_pose(mount), true);
  if (in.has_right)
    bag.transform(offset + dataset->timestamp(0), "base_link", "camera_right_optical",
                  to_pose(mount * SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(in.baseline, 0, 0))),
                  true);
  for (size_t i = 0; i < n; ++i) {
    Frame f = dataset->frame(i);
    const double t = offset + f.timestamp;
    if (f.gt_pose) {
      // The body's pose twice, as robots publish it: tf, and an Odometry topic.
      const rb::Pose body = to_pose(*f.gt_pose * mount.inverse());
      bag.transform(t, "world", "base_link", body, false);
      bag.odometry("/odometry", t, "world", "base_link", body);
    }
    bag.camera_info(left_info, t, camera_info(f.camera, 0, left_frame));
    bag.image(left_topic, t, left_frame, picture(f.left));
    if (f.right) {
      bag.camera_info("/stereo/right/camera_info", t,
                      camera_info(f.camera, f.baseline, "camera_right_optical"));
      bag.image("/stereo/right/image_rect", t, "camera_right_optical", picture(*f.right));
    }
    if (rgbd && f.depth) bag.image("/camera/depth/image_raw", t, left_frame, picture(*f.depth));
  }
  bag.close();
  std::cout << "wrote " << argv[2] << ": " << n << " frames, "
            << (rgbd           ? "RGB-D"
                : in.has_right ? "stereo"
                               : "mono")
            << ", time offset " << offset << " s\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return convert(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
