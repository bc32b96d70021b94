// Conversions between ROS 1 messages and the library's plain structs (rosbag_io.hpp), shared by the
// bag reader, the bag writer and the node. C++17: includes ROS message headers.
#pragma once
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <string>

#include "chungs/datasets/rosbag_io.hpp"

namespace chungs::rosbag_io {

enum class ImageKind { Intensity, Depth };

// Decodes an Image message: mono8, rgb8, bgr8, rgba8, bgra8 (alpha dropped, BGR swapped) for
// intensity; 32FC1 (metres, NaN and inf become 0) and 16UC1 / mono16 (millimetres, REP 118) for depth.
// `where` names the message in errors ("bag.bag: topic /left at 12.3 s").
Picture decode_image(const sensor_msgs::Image& msg, ImageKind kind, const std::string& where);
sensor_msgs::Image encode_image(const Picture& picture);

CameraInfo from_msg(const sensor_msgs::CameraInfo& msg, const std::string& topic);
sensor_msgs::CameraInfo to_msg(const CameraInfo& info);

}  // namespace chungs::rosbag_io
