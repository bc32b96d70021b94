// Where a frame's depth comes from: the sensor (RGB-D), stereo matching, or nowhere.
#pragma once
#include <optional>
#include <string>

#include "chungs/datasets/frame.hpp"
#include "chungs/depth/stereo_depth.hpp"

namespace chungs {

enum class DepthMode { Auto, Sensor, Stereo, None };

DepthMode parse_depth_mode(const std::string& name);  // auto|sensor|stereo|none, else Error
const char* depth_mode_name(DepthMode mode);
// Auto picks sensor depth when the frame has it, else stereo when it has a right image, else none.
DepthMode resolve_depth_mode(DepthMode mode, bool has_depth, bool has_right);

// The frame's depth (metres, 0 invalid) by the mode, or nothing for None. Throws Error naming the
// frame when the mode needs data the frame lacks.
std::optional<ImageF> frame_depth(const Frame& frame, DepthMode mode, const StereoDepthConfig& stereo = {});

}  // namespace chungs
