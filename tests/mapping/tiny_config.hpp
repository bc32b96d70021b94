// The mapping settings the tests share: the indoor preset on tiny images (denser sampling, small
// chunks), nothing flushed to disk, no renders or keyframe scoring at the end. Tests change what
// they exercise on top of it.
#pragma once
#include "chungs/config/config.hpp"

namespace chungs::test {

inline Config tiny_mapping_config() {
  Config c;
  c.loss = LossConfig::indoor();
  c.adam.lr_position = 1e-3f;
  // The rates as given: at 64x48 the small-image factor (4x) prunes these maps below the sizes the
  // tests set up around their budgets; AdamRates tests the factor itself.
  c.adam.small_image_reference_px = 0;
  c.store.chunk_size = 1.0;
  c.store.durable = false;
  c.keyframes.durable = false;
  c.sampler.min_per_chunk_per_100k_px = 10 * 1e5 / (64 * 48);  // 10 Gaussians on the 64x48 wall
  c.sampler.min_per_chunk_floor = 0;
  c.sampler.density = 4.0;  // tiny images: more samples per pixel of edge
  c.sampler.empty_floor = 0.1;
  c.mapper.iterations_per_keyframe = 12;
  c.mapper.final_iterations = 60;
  c.mapper.checkpoint_every = 2;
  c.mapper.checkpoint_max_share = 0;  // checkpoints where the tests expect them, whatever they cost
  c.mapper.keyframe_every = 1;        // the tiny sequences move too little for the parallax rule
  c.sampler.new_per_step = 0;         // tiny images sample fewer than any cap worth testing here
  c.mapper.eval_keyframe_stride = 0;
  c.mapper.max_saved_renders = 0;
  c.residency.budget_gaussians = 200'000;
  return c;
}

}  // namespace chungs::test
