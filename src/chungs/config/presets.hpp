// The run presets of `diskchungs run` and `diskchungs demo`, and of the tests that map as `run` does:
// outdoor (KITTI) and indoor settings differ in the depth weight, the position learning rate
// (PAPER.md), the far-field fill depth and the sky.
#pragma once
#include <string>

#include "chungs/config/config.hpp"

namespace chungs {

// preset: auto (outdoor for kitti: and synth-street: datasets, indoor otherwise) | outdoor | indoor.
void apply_preset(Config& c, const std::string& preset, const std::string& dataset);

}  // namespace chungs
