// The seam between the library (C++20) and ROS 1 (whose message headers only compile as C++17):
// plain structs and two classes whose bodies live in ros/bag/ and are the only code that includes
// ROS headers. Keep this header C++17 and free of the library's other headers, so both sides
// compile it. Errors are chungs::Error naming the bag file and the topic at fault.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace chungs::rosbag_io {

// Which topics of a bag make the frames. Stereo: left + right; RGB-D: color + depth; monocular:
// left alone. An empty *_info topic means "camera_info beside the image topic" (ROS convention).
struct Topics {
  std::string left, right, left_info, right_info;
  std::string color, depth, info;
  std::string world = "world";  // tf frame the ground-truth poses are expressed in
  std::string camera;           // tf frame of the (left/colour) camera; empty: the image header's frame_id
  double sync = 0.02;           // seconds two images of one frame may be apart (header stamps)
};

// sensor_msgs/CameraInfo as read, with the topic it came from.
struct CameraInfo {
  std::string topic, frame_id, distortion_model;
  int width = 0, height = 0;
  std::vector<double> D;
  std::array<double, 9> K{}, R{};
  std::array<double, 12> P{};
};

// An image as the library wants it: 8-bit gray or RGB pixels, or depth in metres (0 = invalid).
struct Picture {
  int width = 0, height = 0, channels = 0;
  std::vector<uint8_t> pixels;  // interleaved, row-major; empty for depth
  std::vector<float> metres;    // depth only
};

// Camera-to-world, quaternion (x, y, z, w).
struct Pose {
  std::array<double, 3> t{};
  std::array<double, 4> q{0, 0, 0, 1};
};

// Opens a bag with no ROS master: indexes the frames' messages (pairing the two images of a frame by
// header stamp), reads the camera_info topics and every /tf and /tf_static message so that poses can
// be looked up without a master. Images are read on demand; reads are serialised (a bag is one file
// cursor).
class BagReader {
 public:
  BagReader(const std::string& file, const Topics& topics);
  ~BagReader();
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  size_t frames() const;
  double stamp(size_t i) const;                     // header stamp of the left/colour image, seconds
  const std::optional<Pose>& pose(size_t i) const;  // tf world <- camera at that stamp, if known
  bool has_poses() const;
  const CameraInfo& info() const;        // left or colour camera
  const CameraInfo* right_info() const;  // stereo only
  std::string camera_frame() const;      // tf frame the poses belong to
  // which: 0 = left/colour, 1 = right, 2 = depth. Throws naming topic and stamp for a bad message.
  Picture image(size_t i, int which) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes a bag (for tests and for turning a dataset into a recording): images, camera_info and tf.
class BagWriter {
 public:
  explicit BagWriter(const std::string& file);
  ~BagWriter();
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  // 8-bit pictures become mono8 or rgb8, depth pictures 32FC1 in metres.
  void image(const std::string& topic, double stamp, const std::string& frame_id, const Picture& picture);
  void camera_info(const std::string& topic, double stamp, const CameraInfo& info);
  // One transform parent <- child (child-to-parent); static ones go to /tf_static.
  void transform(double stamp, const std::string& parent, const std::string& child, const Pose& pose,
                 bool is_static);
  // nav_msgs/Odometry: `child`'s pose in `parent` (no twist), as a robot's localisation publishes it.
  void odometry(const std::string& topic, double stamp, const std::string& parent, const std::string& child,
                const Pose& pose);
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace chungs::rosbag_io
