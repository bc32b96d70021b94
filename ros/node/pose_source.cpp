#include "ros/node/pose_source.hpp"

#include <tf2/LinearMath/Quaternion.h>
#include <tf2/LinearMath/Transform.h>
#include <tf2/exceptions.h>

#include <chrono>

#include "chungs/common/error.hpp"

namespace chungs::ros_node {

namespace {

tf2::Transform to_tf(const rosbag_io::Pose& p) {
  return tf2::Transform(tf2::Quaternion(p.q[0], p.q[1], p.q[2], p.q[3]),
                        tf2::Vector3(p.t[0], p.t[1], p.t[2]));
}

rosbag_io::Pose from_tf(const tf2::Transform& t) {
  const tf2::Quaternion q = t.getRotation();
  const tf2::Vector3& o = t.getOrigin();
  return {{o.x(), o.y(), o.z()}, {q.x(), q.y(), q.z(), q.w()}};
}

rosbag_io::Pose from_msg(const geometry_msgs::Pose& p) {
  return {{p.position.x, p.position.y, p.position.z},
          {p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w}};
}

}  // namespace

PoseSource::PoseSource(ros::NodeHandle& nh, ros::NodeHandle& pnh, tf2_ros::Buffer& tf) : tf_(tf) {
  pnh.param<std::string>("pose_source", mode_, "tf");
  pnh.param<std::string>("world_frame", world_, "world");
  pnh.param<std::string>("camera_frame", camera_override_, "");
  pnh.param("pose_max_dt", max_dt_, 0.1);
  pnh.param("tf_timeout", tf_timeout_, 0.5);
  if (mode_ == "pose") {
    sub_ = nh.subscribe<geometry_msgs::PoseStamped>(
        "pose", 200, [this](const geometry_msgs::PoseStampedConstPtr& m) { add(m->header, m->pose); });
  } else if (mode_ == "odometry") {
    sub_ = nh.subscribe<nav_msgs::Odometry>("odometry", 200, [this](const nav_msgs::OdometryConstPtr& m) {
      {
        std::lock_guard lock(mutex_);
        if (body_frame_.empty()) body_frame_ = m->child_frame_id;
      }
      add(m->header, m->pose.pose);
    });
  } else if (mode_ != "tf" && mode_ != "track") {
    fail("~pose_source must be tf, pose, odometry or track, got '", mode_, "'");
  }
  if (mode_ == "pose") pnh.param<std::string>("body_frame", body_frame_, "base_link");
}

void PoseSource::add(const std_msgs::Header& header, const geometry_msgs::Pose& pose) {
  if (!header.frame_id.empty() && header.frame_id != world_) {
    ROS_WARN_THROTTLE(5, "pose in frame '%s', expected ~world_frame '%s': ignored", header.frame_id.c_str(),
                      world_.c_str());
    return;
  }
  {
    std::lock_guard lock(mutex_);
    const double t = header.stamp.toSec();
    if (!poses_.empty() && t <= poses_.back().first) return;
    poses_.emplace_back(t, from_msg(pose));
    while (poses_.size() > 10000) poses_.pop_front();
  }
  arrived_.notify_all();
}

std::optional<rosbag_io::Pose> PoseSource::at(const ros::Time& stamp, const std::string& image_frame) {
  const std::string camera = camera_override_.empty() ? image_frame : camera_override_;
  {
    std::lock_guard lock(mutex_);
    last_camera_ = camera;
  }
  try {
    if (mode_ == "tf") {
      auto t = tf_.lookupTransform(world_, camera, stamp, ros::Duration(tf_timeout_));
      const auto& tr = t.transform.translation;
      const auto& q = t.transform.rotation;
      return rosbag_io::Pose{{tr.x, tr.y, tr.z}, {q.x, q.y, q.z, q.w}};
    }
    std::string body;
    rosbag_io::Pose world_body;
    {
      std::unique_lock lock(mutex_);
      const double t = stamp.toSec();
      // The image may come before the pose of its stamp (another topic): wait for it a little.
      arrived_.wait_for(lock, std::chrono::duration<double>(tf_timeout_),
                        [&] { return !poses_.empty() && poses_.back().first >= t; });
      body = body_frame_;
      auto after = std::lower_bound(poses_.begin(), poses_.end(), t,
                                    [](const auto& p, double v) { return p.first < v; });
      if (after != poses_.end() && after->first == t) {
        world_body = after->second;
      } else if (after == poses_.end() || after == poses_.begin()) {
        ROS_WARN_THROTTLE(5, "no %s message around image stamp %.3f", mode_.c_str(), t);
        return std::nullopt;
      } else {
        const auto& b = *after;
        const auto& a = *std::prev(after);
        if (t - a.first > max_dt_ || b.first - t > max_dt_) {
          ROS_WARN_THROTTLE(5, "%s messages around image stamp %.3f are more than ~pose_max_dt apart",
                            mode_.c_str(), t);
          return std::nullopt;
        }
        // Between two robot poses: position linearly, rotation by slerp.
        const double w = (t - a.first) / (b.first - a.first);
        const tf2::Transform ta = to_tf(a.second), tb = to_tf(b.second);
        world_body = from_tf(tf2::Transform(ta.getRotation().slerp(tb.getRotation(), w),
                                            ta.getOrigin().lerp(tb.getOrigin(), w)));
      }
    }
    // The camera's mount on the robot is static: the latest transform serves.
    auto mount = tf_.lookupTransform(body, camera, ros::Time(0), ros::Duration(tf_timeout_));
    const auto& mt = mount.transform;
    const tf2::Transform body_camera(
        tf2::Quaternion(mt.rotation.x, mt.rotation.y, mt.rotation.z, mt.rotation.w),
        tf2::Vector3(mt.translation.x, mt.translation.y, mt.translation.z));
    return from_tf(to_tf(world_body) * body_camera);
  } catch (const tf2::TransformException& e) {
    ROS_WARN_THROTTLE(5, "no pose for camera frame '%s' at %.3f: %s", camera.c_str(), stamp.toSec(),
                      e.what());
    return std::nullopt;
  }
}

std::optional<rosbag_io::Pose> PoseSource::camera_pose(const rosbag_io::Pose& reported) {
  if (mode_ == "tf" || mode_ == "track") return reported;
  std::string body, camera;
  {
    std::lock_guard lock(mutex_);
    body = body_frame_;
    camera = last_camera_;
  }
  if (body.empty() || camera.empty()) return std::nullopt;
  try {
    const auto mt = tf_.lookupTransform(body, camera, ros::Time(0), ros::Duration(tf_timeout_)).transform;
    const tf2::Transform mount(tf2::Quaternion(mt.rotation.x, mt.rotation.y, mt.rotation.z, mt.rotation.w),
                               tf2::Vector3(mt.translation.x, mt.translation.y, mt.translation.z));
    return from_tf(to_tf(reported) * mount);
  } catch (const tf2::TransformException& e) {
    ROS_WARN_THROTTLE(5, "no camera mount %s <- %s for a correction: %s", body.c_str(), camera.c_str(),
                      e.what());
    return std::nullopt;
  }
}

}  // namespace chungs::ros_node
