// Where the node's camera poses come from: tf (world <- camera optical frame at the image stamp),
// or a geometry_msgs/PoseStamped or nav_msgs/Odometry topic of the robot's body, with the camera's
// mount (body <- camera) from tf. Either way the robot's own localisation is trusted as it is.
#pragma once
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <string>

#include "chungs/datasets/rosbag_io.hpp"

namespace chungs::ros_node {

class PoseSource {
 public:
  // Reads ~pose_source (tf | pose | odometry), ~world_frame, ~camera_frame, ~body_frame, ~pose_max_dt,
  // ~tf_timeout. `nh` subscribes the pose topic: give it a callback queue other than the images', so
  // that an image may wait for the pose message of its own stamp.
  PoseSource(ros::NodeHandle& nh, ros::NodeHandle& pnh, tf2_ros::Buffer& tf);
  // Camera-to-world of `camera_frame` (the image's frame_id unless ~camera_frame is set) at `stamp`;
  // none (with a throttled warning saying why) when it is not known.
  std::optional<rosbag_io::Pose> at(const ros::Time& stamp, const std::string& camera_frame);
  const std::string& world_frame() const { return world_; }
  // A pose the robot's localisation reports (tf: the camera's; pose / odometry: the body's) as the
  // camera's, for corrections published in the same terms. None while the mount is unknown.
  std::optional<rosbag_io::Pose> camera_pose(const rosbag_io::Pose& reported);

 private:
  void add(const std_msgs::Header& header, const geometry_msgs::Pose& pose);

  tf2_ros::Buffer& tf_;
  std::string mode_, world_, camera_override_;
  double max_dt_ = 0.1, tf_timeout_ = 0.2;
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::string body_frame_, last_camera_;  // last_camera_: the camera frame of the latest image
  std::deque<std::pair<double, rosbag_io::Pose>> poses_;  // body-to-world, by stamp
};

}  // namespace chungs::ros_node
