#include "ros/bag/messages.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "chungs/common/error.hpp"

namespace chungs::rosbag_io {

namespace {

struct Layout {
  const char* encoding;
  int source_channels, channels;  // bytes per pixel in the message, channels kept
  bool swap_rb;
};

constexpr Layout kIntensity[] = {{"mono8", 1, 1, false}, {"8UC1", 1, 1, false}, {"rgb8", 3, 3, false},
                                 {"bgr8", 3, 3, true},   {"8UC3", 3, 3, true},  {"rgba8", 4, 3, false},
                                 {"bgra8", 4, 3, true}};

bool host_big_endian() {
  const uint16_t one = 1;
  uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

// A message whose step or data cannot hold its declared size would make every later read run past
// the buffer: check before touching a pixel.
void check_size(const sensor_msgs::Image& msg, size_t bytes_per_pixel, const std::string& where) {
  if (msg.width == 0 || msg.height == 0) fail(where, ": image is empty (", msg.width, "x", msg.height, ")");
  if (uint64_t(msg.width) * msg.height > (uint64_t(1) << 26))
    fail(where, ": image of ", msg.width, "x", msg.height, " pixels is larger than 8192x8192");
  if (uint64_t(msg.step) < uint64_t(msg.width) * bytes_per_pixel)
    fail(where, ": step ", msg.step, " is shorter than a row of ", msg.width, " ", msg.encoding, " pixels");
  if (uint64_t(msg.data.size()) < uint64_t(msg.step) * msg.height)
    fail(where, ": ", msg.data.size(), " bytes of data for ", msg.height, " rows of ", msg.step, " bytes");
}

template <typename T>
T read_scalar(const uint8_t* p, bool swap) {
  uint8_t b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

Picture decode_depth(const sensor_msgs::Image& msg, const std::string& where) {
  const bool is_float = msg.encoding == "32FC1";
  const bool is_mm = msg.encoding == "16UC1" || msg.encoding == "mono16";
  if (!is_float && !is_mm)
    fail(where, ": depth encoding '", msg.encoding,
         "' is not supported (32FC1 in metres, 16UC1 or mono16 in millimetres)");
  const size_t bpp = is_float ? 4 : 2;
  check_size(msg, bpp, where);
  const bool swap = bool(msg.is_bigendian) != host_big_endian();
  Picture out;
  out.width = int(msg.width);
  out.height = int(msg.height);
  out.channels = 1;
  out.metres.resize(size_t(msg.width) * msg.height);
  for (uint32_t y = 0; y < msg.height; ++y) {
    const uint8_t* row = msg.data.data() + size_t(y) * msg.step;
    float* dst = out.metres.data() + size_t(y) * msg.width;
    for (uint32_t x = 0; x < msg.width; ++x) {
      float d = is_float ? read_scalar<float>(row + x * 4, swap)
                         : 0.001f * float(read_scalar<uint16_t>(row + x * 2, swap));
      dst[x] = std::isfinite(d) && d > 0 ? d : 0.0f;
    }
  }
  return out;
}

}  // namespace

Picture decode_image(const sensor_msgs::Image& msg, ImageKind kind, const std::string& where) {
  if (kind == ImageKind::Depth) return decode_depth(msg, where);
  const Layout* layout = nullptr;
  for (const auto& l : kIntensity)
    if (msg.encoding == l.encoding) layout = &l;
  if (!layout)
    fail(where, ": image encoding '", msg.encoding, "' is not supported (mono8, rgb8, bgr8, rgba8, bgra8)");
  check_size(msg, size_t(layout->source_channels), where);
  Picture out;
  out.width = int(msg.width);
  out.height = int(msg.height);
  out.channels = layout->channels;
  out.pixels.resize(size_t(msg.width) * msg.height * size_t(layout->channels));
  for (uint32_t y = 0; y < msg.height; ++y) {
    const uint8_t* src = msg.data.data() + size_t(y) * msg.step;
    uint8_t* dst = out.pixels.data() + size_t(y) * msg.width * size_t(layout->channels);
    for (uint32_t x = 0; x < msg.width; ++x, src += layout->source_channels, dst += layout->channels) {
      for (int c = 0; c < layout->channels; ++c) dst[c] = src[c];
      if (layout->swap_rb) std::swap(dst[0], dst[2]);
    }
  }
  return out;
}

sensor_msgs::Image encode_image(const Picture& picture) {
  sensor_msgs::Image msg;
  msg.width = uint32_t(picture.width);
  msg.height = uint32_t(picture.height);
  msg.is_bigendian = host_big_endian();
  if (!picture.metres.empty()) {
    msg.encoding = "32FC1";
    msg.step = msg.width * 4;
    msg.data.resize(picture.metres.size() * 4);
    std::memcpy(msg.data.data(), picture.metres.data(), msg.data.size());
    return msg;
  }
  if (picture.channels != 1 && picture.channels != 3)
    fail("image with ", picture.channels, " channels cannot be written as mono8 or rgb8");
  msg.encoding = picture.channels == 1 ? "mono8" : "rgb8";
  msg.step = msg.width * uint32_t(picture.channels);
  msg.data = picture.pixels;
  return msg;
}

CameraInfo from_msg(const sensor_msgs::CameraInfo& msg, const std::string& topic) {
  CameraInfo info;
  info.topic = topic;
  info.frame_id = msg.header.frame_id;
  info.distortion_model = msg.distortion_model;
  info.width = int(msg.width);
  info.height = int(msg.height);
  info.D = msg.D;
  std::copy(msg.K.begin(), msg.K.end(), info.K.begin());
  std::copy(msg.R.begin(), msg.R.end(), info.R.begin());
  std::copy(msg.P.begin(), msg.P.end(), info.P.begin());
  return info;
}

sensor_msgs::CameraInfo to_msg(const CameraInfo& info) {
  sensor_msgs::CameraInfo msg;
  msg.header.frame_id = info.frame_id;
  msg.width = uint32_t(info.width);
  msg.height = uint32_t(info.height);
  msg.distortion_model = info.distortion_model.empty() ? "plumb_bob" : info.distortion_model;
  msg.D = info.D;
  std::copy(info.K.begin(), info.K.end(), msg.K.begin());
  std::copy(info.R.begin(), info.R.end(), msg.R.begin());
  std::copy(info.P.begin(), info.P.end(), msg.P.begin());
  return msg;
}

}  // namespace chungs::rosbag_io
