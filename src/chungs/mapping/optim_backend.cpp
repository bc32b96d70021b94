#include "chungs/mapping/optim_backend.hpp"

#include "chungs/common/error.hpp"
#include "chungs/mapping/cpu_backend.hpp"
#if CHUNGS_WITH_CUDA
#include "chungs/cuda/devices.hpp"
#include "chungs/mapping/cuda/cuda_backend.hpp"
#endif

namespace chungs {

namespace {

// Empty when a CUDA device can be used, else why not.
std::string cuda_unavailable() {
#if CHUNGS_WITH_CUDA
  std::string why;
  if (cuda::list_devices(&why).empty())
    return "no CUDA device (" + (why.empty() ? std::string("none found") : why) + ")";
  return {};
#else
  return "this build has no CUDA backend (configure with -DCHUNGS_CUDA=ON and nvcc)";
#endif
}

}  // namespace

std::string resolve_device(const std::string& device) {
  if (device == "cpu") return device;
  if (device == "cuda") {
    const std::string why = cuda_unavailable();
    if (!why.empty()) fail("device cuda: ", why, "; use --device cpu");
    return device;
  }
  if (device == "auto") return cuda_unavailable().empty() ? "cuda" : "cpu";
  fail("device must be auto, cuda or cpu, got '", device, "'");
}

std::unique_ptr<OptimBackend> make_optim_backend(const std::string& device, size_t capacity, int sh_degree,
                                                 const RasterConfig& raster, size_t target_cache_bytes,
                                                 size_t target_cache_entries) {
  const std::string d = resolve_device(device);
#if CHUNGS_WITH_CUDA
  if (d == "cuda")
    return std::make_unique<cuda::CudaOptimBackend>(capacity, sh_degree, raster, target_cache_bytes,
                                                    target_cache_entries);
#endif
  (void)target_cache_bytes, (void)target_cache_entries;  // the CPU backend reads the store's host copies
  return std::make_unique<CpuOptimBackend>(capacity, sh_degree, raster);
}

}  // namespace chungs
