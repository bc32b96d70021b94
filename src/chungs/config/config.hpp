// The one configuration tree: every module's settings with their defaults (written in each module's
// own config struct), loadable from YAML and printable by `diskchungs info --config`.
#pragma once
#include <filesystem>
#include <string>

#include "chungs/common/error.hpp"
#include "chungs/depth/multiview_depth.hpp"
#include "chungs/depth/stereo_depth.hpp"
#include "chungs/mapping/keyframe_selector.hpp"
#include "chungs/mapping/mapper_config.hpp"
#include "chungs/mapping/sampler.hpp"
#include "chungs/optim/adam.hpp"
#include "chungs/optim/loss_config.hpp"
#include "chungs/optim/prune.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/sky.hpp"
#include "chungs/residency/frustum_culler.hpp"
#include "chungs/residency/residency.hpp"
#include "chungs/store/chunk_store.hpp"
#include "chungs/store/keyframe_store.hpp"

namespace chungs {

struct Config {
  ChunkStoreConfig store;
  KeyframeStoreConfig keyframes;
  ResidencyConfig residency;
  CullerConfig culling;
  RasterConfig raster;
  LossConfig loss;
  AdamConfig adam;
  PruneConfig prune;
  MapperConfig mapper;
  SamplerConfig sampler;
  KeyframeSelectorConfig selector;
  StereoDepthConfig stereo;
  MultiviewDepthConfig multiview;  // one camera (issue 25)
  SkyConfig sky;

  // Each section's own checks. Inline, so that the mapping library, which takes the whole tree,
  // needs only the section modules it already links and not the YAML code of this module.
  void validate() const {
    store.validate();
    residency.validate();
    adam.validate();
    loss.validate();
    prune.validate();
    raster.validate();
    mapper.validate();
    sampler.validate();
    selector.validate();
    stereo.validate();
    multiview.validate();
    sky.validate();
    if (sky.enabled && (raster.background[0] != 0 || raster.background[1] != 0 || raster.background[2] != 0))
      fail("sky: enabled, it is the background: raster.background must stay 0 0 0");
  }
};

// YAML with one mapping per section (store:, keyframes:, ...). Keys absent from the text keep their
// values in `base` (the defaults, or a preset already applied); an unknown section or key, or a value
// of the wrong type, throws Error naming the source and the key (so a typo never silently falls
// back to a default).
Config config_from_yaml(const std::string& text, const std::string& source = "config", const Config& base = Config());
Config load_config(const std::filesystem::path& file, const Config& base = Config());
std::string config_to_yaml(const Config& config);

}  // namespace chungs
