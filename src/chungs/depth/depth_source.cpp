#include "chungs/depth/depth_source.hpp"

namespace chungs {

DepthMode parse_depth_mode(const std::string& name) {
  if (name == "auto") return DepthMode::Auto;
  if (name == "sensor") return DepthMode::Sensor;
  if (name == "stereo") return DepthMode::Stereo;
  if (name == "multiview") return DepthMode::Multiview;
  if (name == "none") return DepthMode::None;
  fail("depth source '", name, "' is not one of auto, sensor, stereo, multiview, none");
}

const char* depth_mode_name(DepthMode mode) {
  switch (mode) {
    case DepthMode::Auto: return "auto";
    case DepthMode::Sensor: return "sensor";
    case DepthMode::Stereo: return "stereo";
    case DepthMode::Multiview: return "multiview";
    case DepthMode::None: return "none";
  }
  return "?";
}

DepthMode resolve_depth_mode(DepthMode mode, bool has_depth, bool has_right) {
  if (mode != DepthMode::Auto) return mode;
  if (has_depth) return DepthMode::Sensor;
  if (has_right) return DepthMode::Stereo;
  return DepthMode::Multiview;
}

std::optional<ImageF> frame_depth(const Frame& frame, DepthMode mode, const StereoDepthConfig& stereo) {
  mode = resolve_depth_mode(mode, frame.depth.has_value(), frame.right.has_value());
  switch (mode) {
    case DepthMode::None:
    case DepthMode::Multiview: return std::nullopt;
    case DepthMode::Sensor:
      if (!frame.depth) fail("frame ", frame.index, " (", frame.source, "): depth source 'sensor' but the frame has no depth");
      return *frame.depth;
    case DepthMode::Stereo:
      if (!frame.right || frame.baseline <= 0)
        fail("frame ", frame.index, " (", frame.source, "): depth source 'stereo' but the frame has no right image/baseline");
      return stereo_depth(frame.left, *frame.right, frame.camera.fx, frame.baseline, stereo).depth;
    case DepthMode::Auto: break;
  }
  fail("frame ", frame.index, ": unresolved depth mode");
}

}  // namespace chungs
