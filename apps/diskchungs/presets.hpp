// The run presets shared by `diskchungs run` and `diskchungs demo`: outdoor (KITTI) and indoor
// settings differ in the depth weight, the position learning rate (PAPER.md) and the sky fill.
#pragma once
#include <string>

#include "chungs/config/config.hpp"

namespace chungs::app {

// preset: auto (outdoor for kitti: and synth-street: datasets, indoor otherwise) | outdoor | indoor.
void apply_preset(Config& c, const std::string& preset, const std::string& dataset);

}  // namespace chungs::app
