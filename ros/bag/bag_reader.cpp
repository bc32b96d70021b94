// BagReader: a bag's frames, cameras and tf poses, read with the rosbag C++ API and no master.
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Header.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "ros/bag/messages.hpp"

// Indexing a bag must not deserialise every image: this type reads only the Header every stamped
// message starts with, and its "*" checksum lets rosbag hand it any message type.
namespace chungs::rosbag_io {
struct LeadingHeader {
  std_msgs::Header header;
};
}  // namespace chungs::rosbag_io

namespace ros::message_traits {
template <>
struct MD5Sum<chungs::rosbag_io::LeadingHeader> {
  static const char* value() { return "*"; }
  static const char* value(const chungs::rosbag_io::LeadingHeader&) { return "*"; }
};
template <>
struct DataType<chungs::rosbag_io::LeadingHeader> {
  static const char* value() { return "*"; }
  static const char* value(const chungs::rosbag_io::LeadingHeader&) { return "*"; }
};
template <>
struct Definition<chungs::rosbag_io::LeadingHeader> {
  static const char* value() { return ""; }
  static const char* value(const chungs::rosbag_io::LeadingHeader&) { return ""; }
};
}  // namespace ros::message_traits

namespace ros::serialization {
template <>
struct Serializer<chungs::rosbag_io::LeadingHeader> {
  template <typename Stream>
  static void read(Stream& stream, chungs::rosbag_io::LeadingHeader& m) {
    stream.next(m.header);
  }
};
}  // namespace ros::serialization

namespace chungs::rosbag_io {

namespace {

std::string default_info_topic(const std::string& image_topic) {
  auto slash = image_topic.rfind('/');
  return (slash == std::string::npos ? std::string() : image_topic.substr(0, slash)) + "/camera_info";
}

// MessageInstance cannot be assigned (sorting moves elements): held by pointer.
using Message = std::shared_ptr<const rosbag::MessageInstance>;

struct Stamped {
  double stamp;
  Message message;
};

}  // namespace

struct BagReader::Impl {
  std::string file;
  Topics topics;
  rosbag::Bag bag;
  std::map<std::string, std::string> types;   // topic -> message type
  std::vector<std::vector<Message>> streams;  // per frame: left/colour, right, depth
  std::vector<std::string> stream_topics;
  std::vector<double> stamps;
  std::vector<std::optional<Pose>> poses;
  bool has_poses = false;
  CameraInfo info, right_info;
  bool stereo = false;
  std::string camera_frame;
  mutable std::mutex mutex;

  std::string where(const std::string& topic) const { return file + ": topic " + topic; }

  void require_topic(const std::string& topic, const std::string& type, const std::string& key) const {
    auto it = types.find(topic);
    if (it == types.end()) {
      std::string known;
      for (const auto& [t, ty] : types) known += (known.empty() ? "" : ", ") + t + " (" + ty + ")";
      fail(file, ": no messages on topic ", topic, " (", key, "=); the bag has ",
           known.empty() ? "no topics" : known);
    }
    if (it->second != type) fail(where(topic), " carries ", it->second, ", expected ", type, " (", key, "=)");
  }

  std::vector<Stamped> index(const std::string& topic) {
    std::vector<Stamped> out;
    rosbag::View view(bag, rosbag::TopicQuery(topic));
    for (const auto& m : view) {
      auto h = m.instantiate<LeadingHeader>();
      if (!h) fail(where(topic), ": a message could not be read");
      if (camera_frame.empty() && streams.empty()) camera_frame = h->header.frame_id;
      out.push_back({h->header.stamp.toSec(), std::make_shared<const rosbag::MessageInstance>(m)});
    }
    std::stable_sort(out.begin(), out.end(),
                     [](const Stamped& a, const Stamped& b) { return a.stamp < b.stamp; });
    // A repeated stamp is the same instant sent twice; a frame needs stamps that increase. Said, since
    // a bag whose stamps were all one (a driver that never set them) became a single frame unsaid.
    const size_t before = out.size();
    out.erase(std::unique(out.begin(), out.end(),
                          [](const Stamped& a, const Stamped& b) { return a.stamp == b.stamp; }),
              out.end());
    if (out.size() < before)
      log::warn(where(topic), ": ", before - out.size(), " of ", before,
                " images repeat the header stamp of the one before and are skipped (one image per instant)");
    return out;
  }

  CameraInfo read_info(const std::string& topic, const std::string& key) {
    require_topic(topic, "sensor_msgs/CameraInfo", key);
    rosbag::View view(bag, rosbag::TopicQuery(topic));
    for (const auto& m : view) {
      auto msg = m.instantiate<sensor_msgs::CameraInfo>();
      if (!msg) break;
      CameraInfo info = from_msg(*msg, topic);
      if (info.width <= 0 || info.height <= 0) fail(where(topic), ": camera_info has no image size");
      if (!(info.P[0] > 0 && info.P[5] > 0))
        fail(where(topic), ": camera_info's projection P has no positive focal lengths");
      return info;
    }
    fail(where(topic), ": no camera_info message could be read");
  }

  // Frames are the first stream's images that have a partner within `sync` seconds in the second.
  void pair(const std::vector<Stamped>& first, const std::vector<Stamped>& second) {
    streams.assign(second.empty() ? 1 : 2, {});
    size_t dropped = 0;
    for (const auto& f : first) {
      if (!second.empty()) {
        auto it = std::lower_bound(second.begin(), second.end(), f.stamp,
                                   [](const Stamped& s, double t) { return s.stamp < t; });
        const Stamped* best = nullptr;
        if (it != second.end()) best = &*it;
        if (it != second.begin() && (!best || f.stamp - std::prev(it)->stamp < best->stamp - f.stamp))
          best = &*std::prev(it);
        if (!best || std::abs(best->stamp - f.stamp) > topics.sync) {
          ++dropped;
          continue;
        }
        streams[1].push_back(best->message);
      }
      streams[0].push_back(f.message);
      stamps.push_back(f.stamp);
    }
    if (stamps.empty())
      fail(file, ": no image on ", stream_topics[0], " has a partner on ", stream_topics[1], " within ",
           topics.sync, " s (sync=)");
    if (dropped > 0)
      log::warn(file, ": ", dropped, " of ", first.size(), " images on ", stream_topics[0], " have no partner on ",
                stream_topics[1], " within ", topics.sync, " s (sync=) and are skipped");
  }

  void read_tf() {
    std::vector<std::string> tf_topics;
    for (const char* t : {"/tf", "/tf_static"})
      if (types.count(t) && types[t] == "tf2_msgs/TFMessage") tf_topics.push_back(t);
    const std::string world = topics.world.empty() ? "world" : topics.world;
    if (tf_topics.empty()) {
      if (!topics.world.empty())
        fail(file, ": world=", topics.world, " given but the bag has no /tf or /tf_static");
      return;
    }
    rosbag::View all(bag, rosbag::TopicQuery(tf_topics));
    // Keep every transform of the recording: the buffer prunes what is older than its cache time.
    const double span = all.getEndTime().toSec() - all.getBeginTime().toSec();
    tf2::BufferCore buffer(ros::Duration(std::max(10.0, span + 10.0)));
    for (const auto& m : all) {
      auto msg = m.instantiate<tf2_msgs::TFMessage>();
      if (!msg) continue;
      for (const auto& t : msg->transforms) buffer.setTransform(t, "bag", m.getTopic() == "/tf_static");
    }
    if (!topics.camera.empty()) camera_frame = topics.camera;
    if (!buffer._frameExists(world)) {
      if (!topics.world.empty()) fail(file, ": tf has no frame '", world, "' (world=)");
      return;
    }
    if (!buffer._frameExists(camera_frame))
      fail(file, ": tf has no frame '", camera_frame,
           "' for the camera (the image header's frame_id; set camera=)");
    poses.assign(stamps.size(), std::nullopt);
    std::string first_error;
    for (size_t i = 0; i < stamps.size(); ++i) {
      try {
        auto t = buffer.lookupTransform(world, camera_frame, ros::Time(stamps[i]));
        const auto& tr = t.transform.translation;
        const auto& q = t.transform.rotation;
        poses[i] = Pose{{tr.x, tr.y, tr.z}, {q.x, q.y, q.z, q.w}};
        has_poses = true;
      } catch (const tf2::TransformException& e) {
        if (first_error.empty()) first_error = e.what();
      }
    }
    if (!has_poses) fail(file, ": tf gives no pose of '", camera_frame, "' in '", world, "': ", first_error);
  }

  void open(const std::string& path, const Topics& t) {
    file = path;
    topics = t;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
      fail(path, ": not a bag file (does not exist or is not a file)");
    bag.open(path, rosbag::bagmode::Read);
    rosbag::View everything(bag);
    for (const auto* c : everything.getConnections()) types[c->topic] = c->datatype;

    stereo = !t.right.empty();
    const bool rgbd = !t.color.empty();
    const std::string first = rgbd ? t.color : t.left;
    const std::string second = rgbd ? t.depth : t.right;
    const char* first_key = rgbd ? "color" : "left";
    require_topic(first, "sensor_msgs/Image", first_key);
    if (!second.empty()) require_topic(second, "sensor_msgs/Image", rgbd ? "depth" : "right");
    const std::string info_topic = rgbd ? (t.info.empty() ? default_info_topic(first) : t.info)
                                        : (t.left_info.empty() ? default_info_topic(first) : t.left_info);
    info = read_info(info_topic, rgbd ? "info" : "left_info");
    if (stereo)
      right_info = read_info(t.right_info.empty() ? default_info_topic(second) : t.right_info, "right_info");

    stream_topics = {first, second};
    auto a = index(first);
    if (a.empty()) fail(where(first), ": no images");
    auto b = second.empty() ? std::vector<Stamped>{} : index(second);
    if (!second.empty() && b.empty()) fail(where(second), ": no images");
    pair(a, b);
    if (rgbd) stream_topics = {first, "", second};
    read_tf();
  }
};

BagReader::BagReader(const std::string& file, const Topics& topics) : impl_(std::make_unique<Impl>()) {
  try {
    impl_->open(file, topics);
  } catch (const rosbag::BagException& e) {
    // rosbag reports a cut-off file as a short read; say what that usually means.
    const std::string what = e.what();
    fail(file, ": cannot read the bag: ", what,
         what.find("wanted") != std::string::npos
             ? " (the file is truncated or its index is missing; `rosbag reindex` "
               "repairs an unfinished recording)"
             : "");
  } catch (const ros::Exception& e) {
    fail(file, ": ", e.what());
  }
}

BagReader::~BagReader() = default;

size_t BagReader::frames() const { return impl_->stamps.size(); }
double BagReader::stamp(size_t i) const { return impl_->stamps.at(i); }
const std::optional<Pose>& BagReader::pose(size_t i) const {
  static const std::optional<Pose> none;
  return impl_->poses.empty() ? none : impl_->poses.at(i);
}
bool BagReader::has_poses() const { return impl_->has_poses; }
const CameraInfo& BagReader::info() const { return impl_->info; }
const CameraInfo* BagReader::right_info() const { return impl_->stereo ? &impl_->right_info : nullptr; }
std::string BagReader::camera_frame() const { return impl_->camera_frame; }

Picture BagReader::image(size_t i, int which) const {
  const Impl& m = *impl_;
  const size_t stream = which == 2 ? 1 : size_t(which);
  if (i >= m.stamps.size() || stream >= m.streams.size())
    fail(m.file, ": frame ", i, " stream ", which, " is out of range (", m.stamps.size(), " frames)");
  const std::string& topic = m.stream_topics[size_t(which)];
  const std::string where = m.where(topic) + " at " + std::to_string(m.stamps[i]) + " s";
  std::lock_guard<std::mutex> lock(m.mutex);
  try {
    auto msg = m.streams[stream][i]->instantiate<sensor_msgs::Image>();
    if (!msg) fail(where, ": not a sensor_msgs/Image");
    Picture p = decode_image(*msg, which == 2 ? ImageKind::Depth : ImageKind::Intensity, where);
    const CameraInfo& cam = which == 1 ? m.right_info : m.info;
    if (p.width != cam.width || p.height != cam.height)
      fail(where, ": image is ", p.width, "x", p.height, " but ", cam.topic, " says ", cam.width, "x",
           cam.height);
    return p;
  } catch (const rosbag::BagException& e) {
    fail(where, ": cannot read the message: ", e.what());
  } catch (const ros::Exception& e) {
    fail(where, ": ", e.what());
  }
}

}  // namespace chungs::rosbag_io
