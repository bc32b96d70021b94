// Where a frame's depth comes from: the sensor (RGB-D), stereo matching, the frame's neighbouring
// keyframes (multiview: one camera, computed by the run, multiview_depth.hpp), or nowhere.
#pragma once
#include <optional>
#include <string>

#include "chungs/datasets/frame.hpp"
#include "chungs/depth/stereo_depth.hpp"

namespace chungs {

enum class DepthMode { Auto, Sensor, Stereo, Multiview, None };

DepthMode parse_depth_mode(const std::string& name);  // auto|sensor|stereo|multiview|none, else Error
const char* depth_mode_name(DepthMode mode);
// Auto picks sensor depth when the frame has it, else stereo when it has a right image, else
// multiview (one camera: depth from the neighbouring keyframes).
DepthMode resolve_depth_mode(DepthMode mode, bool has_depth, bool has_right);

// The frame's depth (metres, 0 invalid) by the mode, or nothing for None and Multiview (a frame alone
// has none: the run sweeps it against earlier keyframes). Throws Error naming the frame when the mode
// needs data the frame lacks.
std::optional<ImageF> frame_depth(const Frame& frame, DepthMode mode, const StereoDepthConfig& stereo = {});

}  // namespace chungs
