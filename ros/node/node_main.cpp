// diskchungs_node: maps live stereo or RGB-D topics on the robot's poses (see README, "ROS 1").
// Subscribes (remap these): stereo  left/image, left/camera_info, right/image, right/camera_info
//                           RGB-D   color/image, color/camera_info, depth/image (registered to colour)
// Publishes ~render (sensor_msgs/Image), ~cloud (sensor_msgs/PointCloud2), ~path (nav_msgs/Path),
// ~status (std_msgs/String, JSON). Services (std_srvs/Trigger): ~checkpoint, ~export, ~stop.
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <nav_msgs/Path.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <sstream>

#include "chungs/common/error.hpp"
#include "ros/bag/messages.hpp"
#include "ros/engine/live_mapper.hpp"
#include "ros/node/params.hpp"
#include "ros/node/pose_source.hpp"

namespace chungs::ros_node {

namespace {

using Image = sensor_msgs::Image;
using SyncPolicy = message_filters::sync_policies::ApproximateTime<Image, Image>;
namespace rb = rosbag_io;

bool rectified(const sensor_msgs::CameraInfo& info) {
  for (double d : info.D)
    if (d != 0) return false;
  for (int k = 0; k < 9; ++k)
    if (std::abs(info.R[k] - (k % 4 == 0 ? 1.0 : 0.0)) > 1e-9) return false;
  return true;
}

class Node {
 public:
  Node() : pnh_("~"), side_("~"), listener_(tf_) {
    // Services, timers (renders, exports, clouds: slow) and pose topics run on their own queue and
    // thread; the image callbacks stay on the global queue, one at a time and in order.
    side_.setCallbackQueue(&side_queue_);
    side_public_.setCallbackQueue(&side_queue_);
    std::string out;
    if (!pnh_.getParam("out", out) || out.empty()) fail("~out (the map folder) is required");
    pnh_.param<std::string>("mode", mode_, "stereo");
    if (mode_ != "stereo" && mode_ != "rgbd") fail("~mode must be stereo or rgbd, got '", mode_, "'");
    live::Settings s;
    s.out = out;
    pnh_.param("resume", s.resume, false);
    pnh_.param<std::string>("device", s.device, "auto");
    pnh_.param<std::string>("preset", s.preset, mode_ == "stereo" ? "outdoor" : "indoor");
    int max_queue = -1;  // a negative count other than -1 is refused by the engine, not clamped
    pnh_.param("max_queue", max_queue, -1);
    s.max_queue = max_queue;
    s.config_yaml = settings_yaml(pnh_);
    std::string pose_source;
    pnh_.param<std::string>("pose_source", pose_source, "tf");
    s.track = pose_source == "track";
    s.source = "ros:" + ros::this_node::getName();
    tracked_ = s.track;
    mapper_ = std::make_unique<live::LiveMapper>(s);
    poses_ = std::make_unique<PoseSource>(side_public_, pnh_, tf_);

    std::string base = out;  // "maps/drive1/" exports to maps/drive1.ply, beside the folder
    while (base.size() > 1 && base.back() == '/') base.pop_back();
    pnh_.param<std::string>("export_path", export_path_, base + ".ply");
    pnh_.param("cloud_radius", cloud_radius_, 30.0);
    double render_period, cloud_period, status_period;
    pnh_.param("render_period", render_period, 1.0);
    pnh_.param("cloud_period", cloud_period, 5.0);  // reads committed chunks from disk: keep it rare
    pnh_.param("status_period", status_period, 1.0);
    int queue;
    pnh_.param("sync_queue", queue, 30);

    // Corrected poses (a loop closure of the robot's localisation) as a nav_msgs/Path by image stamp.
    corrections_sub_ = side_public_.subscribe<nav_msgs::Path>(
        "corrections", 5, [this](const nav_msgs::PathConstPtr& m) { correct(*m); });
    render_pub_ = pnh_.advertise<Image>("render", 1);
    cloud_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("cloud", 1);
    path_pub_ = pnh_.advertise<nav_msgs::Path>("path", 1, true);
    status_pub_ = pnh_.advertise<std_msgs::String>("status", 1, true);

    const bool stereo = mode_ == "stereo";
    info_sub_ = nh_.subscribe<sensor_msgs::CameraInfo>(
        stereo ? "left/camera_info" : "color/camera_info", 5,
        [this](const sensor_msgs::CameraInfoConstPtr& m) { set_info(m, 0); });
    if (stereo)
      right_info_sub_ = nh_.subscribe<sensor_msgs::CameraInfo>(
          "right/camera_info", 5, [this](const sensor_msgs::CameraInfoConstPtr& m) { set_info(m, 1); });
    // Large subscriber queues: a recording played faster than the map is made waits instead of
    // losing frames (~max_queue bounds the backlog inside the mapper).
    first_.subscribe(nh_, stereo ? "left/image" : "color/image", 1000);
    second_.subscribe(nh_, stereo ? "right/image" : "depth/image", 1000);
    sync_ = std::make_unique<message_filters::Synchronizer<SyncPolicy>>(SyncPolicy(queue), first_, second_);
    sync_->registerCallback(
        boost::bind(&Node::frame, this, boost::placeholders::_1, boost::placeholders::_2));

    services_.push_back(side_.advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
        "checkpoint", [this](auto&, auto& res) {
          return call(res, [this] {
            mapper_->checkpoint();
            return std::string("committed");
          });
        }));
    services_.push_back(side_.advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
        "export", [this](auto&, auto& res) { return call(res, [this] { return export_map(); }); }));
    services_.push_back(side_.advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
        "stop", [this](auto&, auto& res) {
          stop_requested_ = true;
          res.success = true;
          res.message = "stopping: the queued frames are mapped, the map refined and committed";
          return true;
        }));
    timers_.push_back(side_.createTimer(ros::Duration(render_period),
                                        [this](const ros::TimerEvent&) { publish_render(); }));
    timers_.push_back(
        side_.createTimer(ros::Duration(cloud_period), [this](const ros::TimerEvent&) { publish_cloud(); }));
    timers_.push_back(side_.createTimer(ros::Duration(status_period),
                                        [this](const ros::TimerEvent&) { publish_status(); }));
    ROS_INFO("diskchungs: mapping %s topics into %s", mode_.c_str(), out.c_str());
  }

  bool stop_requested() const { return stop_requested_; }
  ros::CallbackQueue* side_queue() { return &side_queue_; }

  // Maps what is queued, refines and commits (the folder can then be reopened with ~resume).
  void finish() {
    {
      std::lock_guard lock(pending_mutex_);
      if (!pending_.empty() || not_held_)
        ROS_WARN("diskchungs: %zu frames were never mapped: no camera_info came for them", pending_.size() + not_held_);
    }
    mapper_->finish();
    publish_status();
  }

 private:
  void set_info(const sensor_msgs::CameraInfoConstPtr& m, int which) {
    {
      std::lock_guard lock(info_mutex_);
      (which == 0 ? info_ : right_info_) = m;
    }
    // The frames held for it are mapped now, not when the next frame comes: a recording whose
    // camera_info trails its last images would otherwise leave them unmapped. (The frame callback runs
    // on the same queue, so the order of frames is kept.)
    if (const auto [info, right_info] = known_infos(); info) map_held(info, right_info);
  }

  // Both camera_infos a frame needs (the right one only for stereo), or none while one is missing.
  std::pair<sensor_msgs::CameraInfoConstPtr, sensor_msgs::CameraInfoConstPtr> known_infos() {
    std::lock_guard lock(info_mutex_);
    if (!info_ || (mode_ == "stereo" && !right_info_)) return {};
    return {info_, right_info_};
  }

  void map_held(const sensor_msgs::CameraInfoConstPtr& info, const sensor_msgs::CameraInfoConstPtr& right_info) {
    std::vector<std::pair<sensor_msgs::ImageConstPtr, sensor_msgs::ImageConstPtr>> held;
    {
      std::lock_guard lock(pending_mutex_);
      held.swap(pending_);
    }
    for (const auto& [pa, pb] : held) map_pair(pa, pb, info, right_info);
  }

  void frame(const sensor_msgs::ImageConstPtr& a, const sensor_msgs::ImageConstPtr& b) {
    const auto [info, right_info] = known_infos();
    if (!info) {
      // camera_info comes on its own topic and may trail the first images: hold them, so that a
      // recording's first frames are mapped and frame numbers (held-out frames) match the recording.
      std::lock_guard lock(pending_mutex_);
      if (pending_.size() < kMaxHeld)
        pending_.emplace_back(a, b);
      else
        ++not_held_;
      ROS_WARN_THROTTLE(5, "waiting for camera_info before mapping frames (%zu held, %zu beyond %zu not kept)",
                        pending_.size(), not_held_, kMaxHeld);
      return;
    }
    map_held(info, right_info);
    map_pair(a, b, info, right_info);
  }

  void map_pair(const sensor_msgs::ImageConstPtr& a, const sensor_msgs::ImageConstPtr& b,
                const sensor_msgs::CameraInfoConstPtr& info,
                const sensor_msgs::CameraInfoConstPtr& right_info) {
    const bool stereo = mode_ == "stereo";
    if (!rectified(*info) || (stereo && !rectified(*right_info))) {
      ROS_ERROR_THROTTLE(5,
                         "camera_info has distortion or a rectifying rotation: subscribe to rectified images "
                         "(image_proc / stereo_image_proc) with their camera_info");
      return;
    }
    std::optional<rb::Pose> pose;
    if (!tracked_) {
      pose = poses_->at(a->header.stamp, a->header.frame_id);
      if (!pose) {
        mapper_->skip();
        return;
      }
    }
    try {
      const std::string where = "topic " + first_.getTopic();
      live::LiveFrame f;
      f.stamp = a->header.stamp.toSec();
      f.left = rb::decode_image(*a, rb::ImageKind::Intensity, where);
      if (stereo) {
        f.right = rb::decode_image(*b, rb::ImageKind::Intensity, "topic " + second_.getTopic());
        f.baseline = -right_info->P[3] / right_info->P[0];
      } else {
        f.depth = rb::decode_image(*b, rb::ImageKind::Depth, "topic " + second_.getTopic());
      }
      if (f.left.width != int(info->width) || f.left.height != int(info->height))
        fail(where, ": image is ", f.left.width, "x", f.left.height, " but camera_info says ", info->width,
             "x", info->height);
      f.fx = info->P[0];
      f.fy = info->P[5];
      f.cx = info->P[2];
      f.cy = info->P[6];
      f.pose = pose;
      mapper_->push(std::move(f));
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5, "frame at %.3f skipped: %s", a->header.stamp.toSec(), e.what());
    }
  }

  void correct(const nav_msgs::Path& path) {
    std::vector<std::pair<double, rb::Pose>> poses;
    for (const auto& p : path.poses) {
      const auto& o = p.pose.orientation;
      const auto& t = p.pose.position;
      if (auto cam = poses_->camera_pose(rb::Pose{{t.x, t.y, t.z}, {o.x, o.y, o.z, o.w}}))
        poses.emplace_back(p.header.stamp.toSec(), *cam);
    }
    try {
      const size_t moved = mapper_->correct(poses);
      ROS_INFO("corrections: %zu of %zu poses moved keyframes", moved, poses.size());
      publish_path();
    } catch (const std::exception& e) {
      ROS_ERROR("corrections: %s", e.what());
    }
  }

  template <typename F>
  bool call(std_srvs::Trigger::Response& res, F&& f) {
    try {
      res.message = f();
      res.success = true;
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    return true;
  }

  std::string export_map() {
    std::string file = export_path_;
    pnh_.getParam("export_path", file);  // read at call time: `rosparam set` then call
    std::vector<double> box;
    pnh_.getParam("export_box", box);
    const uint64_t n = mapper_->export_ply(file, box);
    return "wrote " + std::to_string(n) + " Gaussians to " + file;
  }

  void publish_render() {
    if (render_pub_.getNumSubscribers() == 0) return;
    try {
      if (auto p = mapper_->render_latest()) {
        Image msg = rb::encode_image(*p);
        msg.header.stamp = ros::Time::now();
        msg.header.frame_id = "diskchungs_latest_keyframe";
        render_pub_.publish(msg);
      }
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(10, "render: %s", e.what());
    }
  }

  void publish_cloud() {
    publish_path();
    if (cloud_pub_.getNumSubscribers() == 0) return;
    try {
      const std::vector<float> xyz = mapper_->centres(cloud_radius_);
      sensor_msgs::PointCloud2 c;
      c.header.stamp = ros::Time::now();
      c.header.frame_id = poses_->world_frame();
      c.height = 1;
      c.width = uint32_t(xyz.size() / 3);
      const char* names[] = {"x", "y", "z"};
      for (uint32_t k = 0; k < 3; ++k) {
        sensor_msgs::PointField f;
        f.name = names[k];
        f.offset = 4 * k;
        f.datatype = sensor_msgs::PointField::FLOAT32;
        f.count = 1;
        c.fields.push_back(f);
      }
      c.point_step = 12;
      c.row_step = 12 * c.width;
      c.is_dense = true;
      c.data.resize(xyz.size() * 4);
      std::memcpy(c.data.data(), xyz.data(), c.data.size());
      cloud_pub_.publish(c);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(10, "cloud: %s", e.what());
    }
  }

  void publish_path() {
    nav_msgs::Path path;
    path.header.stamp = ros::Time::now();
    path.header.frame_id = poses_->world_frame();
    for (const auto& p : mapper_->keyframe_poses()) {
      geometry_msgs::PoseStamped s;
      s.header.frame_id = path.header.frame_id;
      s.pose.position.x = p.t[0];
      s.pose.position.y = p.t[1];
      s.pose.position.z = p.t[2];
      s.pose.orientation.x = p.q[0];
      s.pose.orientation.y = p.q[1];
      s.pose.orientation.z = p.q[2];
      s.pose.orientation.w = p.q[3];
      path.poses.push_back(s);
    }
    path_pub_.publish(path);
  }

  void publish_status() {
    const live::Status s = mapper_->status();
    std::ostringstream os;
    os << "{\"frames\": " << s.frames << ", \"keyframes\": " << s.keyframes
       << ", \"iterations\": " << s.iterations << ", \"gaussians\": " << s.gaussians
       << ", \"resident\": " << s.resident << ", \"budget\": " << s.budget << ", \"chunks\": " << s.chunks
       << ", \"queued\": " << s.queued << ", \"dropped\": " << s.dropped << ", \"corrected\": " << s.corrected
       << ", \"without_pose\": " << s.without_pose << ", \"io_wait_ms\": " << s.io_wait_ms
       << ", \"steps_per_s\": " << s.steps_per_s << ", \"least_steps_per_keyframe\": " << s.least_steps_per_keyframe
       << ", \"seconds\": " << s.seconds << ", \"error\": \"";
    for (char c : s.error) {
      if (c == '"' || c == '\\') os << '\\';
      os << (c == '\n' ? ' ' : c);
    }
    os << "\"}";
    std_msgs::String msg;
    msg.data = os.str();
    status_pub_.publish(msg);
    if (!s.error.empty()) ROS_ERROR_THROTTLE(10, "mapping stopped: %s", s.error.c_str());
  }

  ros::CallbackQueue side_queue_;
  ros::NodeHandle nh_, pnh_, side_, side_public_;
  tf2_ros::Buffer tf_;
  tf2_ros::TransformListener listener_;
  std::string mode_, export_path_;
  double cloud_radius_ = 30;
  bool tracked_ = false;  // ~pose_source track: the project's tracker makes the poses
  std::unique_ptr<live::LiveMapper> mapper_;
  std::unique_ptr<PoseSource> poses_;
  std::mutex info_mutex_;
  sensor_msgs::CameraInfoConstPtr info_, right_info_;
  ros::Subscriber info_sub_, right_info_sub_, corrections_sub_;
  message_filters::Subscriber<Image> first_, second_;
  std::unique_ptr<message_filters::Synchronizer<SyncPolicy>> sync_;
  ros::Publisher render_pub_, cloud_pub_, path_pub_, status_pub_;
  std::vector<ros::ServiceServer> services_;
  std::vector<ros::Timer> timers_;
  std::atomic<bool> stop_requested_{false};
  std::mutex pending_mutex_;
  std::vector<std::pair<sensor_msgs::ImageConstPtr, sensor_msgs::ImageConstPtr>> pending_;
  static constexpr size_t kMaxHeld = 100;  // frames held for camera_info: seconds of images, not a recording
  size_t not_held_ = 0;                    // frames beyond them, lost (guarded by pending_mutex_)
};

}  // namespace

}  // namespace chungs::ros_node

int main(int argc, char** argv) {
  const std::string allocator = chungs::live::set_process_defaults();
  ros::init(argc, argv, "diskchungs");
  try {
    chungs::ros_node::Node node;
    ROS_INFO("diskchungs: %s", allocator.c_str());  // one arena unless MALLOC_ARENA_MAX or GLIBC_TUNABLES say
    ros::AsyncSpinner side(1, node.side_queue());
    side.start();
    while (ros::ok() && !node.stop_requested())
      ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.05));
    side.stop();
    ROS_INFO("diskchungs: finishing the map");
    node.finish();
    // On stderr as well: after a SIGINT, rosconsole's output may not reach roslaunch any more.
    std::fprintf(stderr, "diskchungs_node: map committed\n");
  } catch (const std::exception& e) {
    // One line on stderr too: rosconsole may not be set up yet when the settings are refused.
    std::fprintf(stderr, "diskchungs_node: error: %s\n", e.what());
    ROS_FATAL("diskchungs: %s", e.what());
    return 1;
  }
  return 0;
}
