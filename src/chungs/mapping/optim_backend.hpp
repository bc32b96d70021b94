// Where the optimisation runs. The mapper drives one OptimBackend: it owns the Gaussian pool that
// Residency fills (host RAM or VRAM), renders an index list of pool slots, and takes one step
// (render, loss, backward, sparse Adam, pruning selection). The CPU and CUDA implementations compute
// the same function; only the place of the arrays and the kernels differ, so the mapper has no
// per-device branches. Include only from C++ files: no CUDA headers here.
#pragma once
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "chungs/mapping/step_targets.hpp"
#include "chungs/optim/adam.hpp"
#include "chungs/optim/loss.hpp"
#include "chungs/optim/prune.hpp"
#include "chungs/render/raster_config.hpp"
#include "chungs/render/render_camera.hpp"
#include "chungs/render/render_output.hpp"
#include "chungs/render/sky.hpp"
#include "chungs/residency/gaussian_pool.hpp"

namespace chungs {

struct SamplerConfig;

struct DeviceMemory {
  double used_mb = 0, total_mb = 0;  // whole device (cudaMemGetInfo), not only this process
};

// Where a backend's steps spent their time, summed over the steps taken while profiling was on
// (milliseconds). host: wall time on the calling thread from one phase boundary to the next, which
// on the GPU is launch work plus any wait for the device inside the phase. device: GPU time between
// the same boundaries (CUDA events on the step's stream; zero on the CPU). Reading the events waits
// for the device at the end of each step, so profiling is off unless a benchmark asks for it.
struct StepPhaseTimes {
  enum Phase { targets, upload, forward, loss, sky, backward, adam, prune, count };
  static constexpr const char* names[count] = {"targets", "upload", "forward", "loss",
                                               "sky",     "backward", "adam", "prune"};
  uint64_t steps = 0;
  double host_ms[count] = {}, device_ms[count] = {};
  double host_total_ms = 0;   // the whole step() call
  double device_span_ms = 0;  // first boundary to last on the device
  // The GPU rasterizer's stages inside forward and backward (device ms; zero on the CPU): where the two
  // largest phases go as the view fills (projection, the depth and tile sorts, compositing).
  enum Stage { preprocess, sort, composite, composite_backward, project_backward, stage_count };
  static constexpr const char* stage_names[stage_count] = {"preprocess", "sort", "composite",
                                                           "composite_backward", "project_backward"};
  double stage_ms[stage_count] = {};
  double tile_entries = 0;  // (tile, Gaussian) pairs rendered, summed over the steps
  // The most crowded tile's entries and the 1 % most crowded tiles' share of all entries, summed over
  // the steps: one block walks a tile, so a few crowded tiles can hold up the whole composite.
  double largest_tile = 0, top_percent_share = 0;
};

class OptimBackend {
 public:
  virtual ~OptimBackend() = default;
  virtual std::string name() const = 0;  // "cpu" or "cuda"
  virtual GaussianPool& pool() = 0;

  // A host copy of the render of the given pool slots; the sky (set_sky) composited behind them when
  // with_sky, else only the raster's background (a pass of a view rendered in several).
  virtual RenderOutput<float> render(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                     bool with_sky) = 0;
  // Room for the next step's slot list of n slots, to be filled and passed to step() before any other
  // call: the GPU backend lends the pinned buffer it uploads from, so the list goes up without a host
  // copy. step() and render() take a list held anywhere all the same.
  virtual std::span<uint32_t> slot_buffer(size_t n) = 0;
  // Renders the slots, evaluates the loss against the targets (the images that `targets` names,
  // converted as host_targets does) and, when slots is non-empty, applies
  // the gradient with sparse Adam to the visible ones. With `prune`, `to_prune` receives the places in
  // `slots` (ascending) of the Gaussians the pruning rule selects after the update (else it is cleared).
  virtual LossTerms step(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                         const StepTargets& targets, const LossConfig& loss, const AdamConfig& adam,
                         const PruneConfig* prune, std::vector<uint32_t>& to_prune) = 0;
  // The sampler's acceptance map (1 channel) for a keyframe image against the render of the slots:
  // chungs::sampling_probability(sampler, image, &render.rgb, &render.alpha), computed where the
  // render lives.
  virtual ImageF sampling_probability(std::span<const uint32_t> slots, const RenderCamera<float>& camera,
                                      const SamplerConfig& sampler, const ImageF& image) = 0;
  // The sky behind the Gaussians (render/sky.hpp): once set, renders, sampling maps and steps
  // composite it, and each step trains it with Adam at `lr`. sky() is a host copy (for checkpoints);
  // none before set_sky().
  virtual void set_sky(const SkyTexture& sky, double lr) = 0;
  virtual std::optional<SkyTexture> sky() const = 0;
  // Device memory now, on a GPU backend; none on the CPU.
  virtual std::optional<DeviceMemory> device_memory() const { return std::nullopt; }
  // Phase timings of the steps taken while on (see StepPhaseTimes); switching on clears them.
  virtual void set_profiling(bool on) = 0;
  // The rasterizer's settings from the next render or step on (e.g. to time segment_entries).
  virtual void set_raster_config(const RasterConfig& raster) = 0;
  virtual const StepPhaseTimes& phase_times() const = 0;
};

// "auto" -> "cuda" when this build has the CUDA backend and a device is present, else "cpu".
// "cuda" without either throws Error saying which is missing; anything but auto|cpu|cuda throws.
std::string resolve_device(const std::string& device);
// A backend for a resolved device with a pool of `capacity` slots; a GPU backend keeps the step targets
// of up to `target_cache_entries` keyframes in up to `target_cache_bytes` of VRAM.
std::unique_ptr<OptimBackend> make_optim_backend(const std::string& device, size_t capacity, int sh_degree,
                                                 const RasterConfig& raster, size_t target_cache_bytes = 0,
                                                 size_t target_cache_entries = SIZE_MAX);

}  // namespace chungs
