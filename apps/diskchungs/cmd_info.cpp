// `diskchungs info`: version, build options, CUDA devices.
#include <cstdio>

#include "command.hpp"
#ifdef CHUNGS_WITH_CUDA
#include "chungs/cuda/devices.hpp"
#endif

namespace chungs::app {
namespace {

int run_info() {
  std::printf("diskchungs %s\n", CHUNGS_VERSION);
  std::printf("build: %s, %s\n", CHUNGS_BUILD_TYPE, CHUNGS_COMPILER);
#ifdef CHUNGS_WITH_CUDA
  std::printf("cuda: built for sm %s, runtime %d\n", CHUNGS_CUDA_ARCHS, cuda::runtime_version());
  std::string why;
  auto devs = cuda::list_devices(&why);
  if (devs.empty()) std::printf("cuda devices: none (%s)\n", why.c_str());
  for (const auto& d : devs)
    std::printf("cuda device %d: %s, sm_%d%d, %d SMs, %.1f GiB (%.1f GiB free)\n", d.index, d.name.c_str(), d.major,
                d.minor, d.multiprocessors, d.total_memory / 1073741824.0, d.free_memory / 1073741824.0);
#else
  std::printf("cuda: not built (configure with CHUNGS_CUDA=ON or AUTO with nvcc present)\n");
#endif
  return 0;
}

const Command info_cmd("info", "version, build options and CUDA devices", [](CLI::App&) -> Action {
  return run_info;
});

}  // namespace
}  // namespace chungs::app
