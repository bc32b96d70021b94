#include "chungs/config/presets.hpp"

#include "chungs/common/error.hpp"

namespace chungs {

void apply_preset(Config& c, const std::string& preset, const std::string& dataset) {
  std::string p = preset;
  if (p == "auto")
    p = dataset.rfind("kitti:", 0) == 0 || dataset.rfind("synth-street:", 0) == 0 ? "outdoor" : "indoor";
  if (p == "outdoor") {
    c.loss = LossConfig::kitti();
    c.sampler.fill_depth = 80.0;  // far field beyond the stereo range
    c.sky.enabled = true;         // the sky behind everything (render/sky.hpp)
  } else if (p == "indoor") {
    c.loss = LossConfig::indoor();
  } else {
    fail("--preset must be auto, outdoor or indoor, got '", preset, "'");
  }
}

}  // namespace chungs
