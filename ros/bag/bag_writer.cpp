// BagWriter: images, camera_info and tf into a bag, through the rosbag C++ API.
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include "chungs/common/error.hpp"
#include "ros/bag/messages.hpp"

namespace chungs::rosbag_io {

struct BagWriter::Impl {
  std::string file;
  rosbag::Bag bag;
};

BagWriter::BagWriter(const std::string& file) : impl_(std::make_unique<Impl>()) {
  impl_->file = file;
  try {
    impl_->bag.open(file, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    fail(file, ": cannot write a bag: ", e.what());
  }
}

BagWriter::~BagWriter() = default;

void BagWriter::image(const std::string& topic, double stamp, const std::string& frame_id,
                      const Picture& picture) {
  sensor_msgs::Image msg = encode_image(picture);
  msg.header.stamp = ros::Time(stamp);
  msg.header.frame_id = frame_id;
  impl_->bag.write(topic, msg.header.stamp, msg);
}

void BagWriter::camera_info(const std::string& topic, double stamp, const CameraInfo& info) {
  sensor_msgs::CameraInfo msg = to_msg(info);
  msg.header.stamp = ros::Time(stamp);
  impl_->bag.write(topic, msg.header.stamp, msg);
}

void BagWriter::transform(double stamp, const std::string& parent, const std::string& child, const Pose& pose,
                          bool is_static) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time(stamp);
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.transform.translation.x = pose.t[0];
  t.transform.translation.y = pose.t[1];
  t.transform.translation.z = pose.t[2];
  t.transform.rotation.x = pose.q[0];
  t.transform.rotation.y = pose.q[1];
  t.transform.rotation.z = pose.q[2];
  t.transform.rotation.w = pose.q[3];
  tf2_msgs::TFMessage msg;
  msg.transforms.push_back(t);
  impl_->bag.write(is_static ? "/tf_static" : "/tf", t.header.stamp, msg);
}

void BagWriter::odometry(const std::string& topic, double stamp, const std::string& parent,
                         const std::string& child, const Pose& pose) {
  nav_msgs::Odometry msg;
  msg.header.stamp = ros::Time(stamp);
  msg.header.frame_id = parent;
  msg.child_frame_id = child;
  auto& p = msg.pose.pose;
  p.position.x = pose.t[0];
  p.position.y = pose.t[1];
  p.position.z = pose.t[2];
  p.orientation.x = pose.q[0];
  p.orientation.y = pose.q[1];
  p.orientation.z = pose.q[2];
  p.orientation.w = pose.q[3];
  impl_->bag.write(topic, msg.header.stamp, msg);
}

void BagWriter::close() { impl_->bag.close(); }

}  // namespace chungs::rosbag_io
