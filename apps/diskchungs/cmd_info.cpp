// `diskchungs info`: version, build options, CUDA devices, and (--config) every config default.
#include <cstdio>

#include "chungs/common/process_defaults.hpp"
#include "chungs/config/config.hpp"
#include "command.hpp"
#ifdef CHUNGS_WITH_CUDA
#include "chungs/cuda/devices.hpp"
#endif

namespace chungs::app {
namespace {

void print_build() {
  std::printf("diskchungs %s\n", CHUNGS_VERSION);
  std::printf("build: %s, %s\n", CHUNGS_BUILD_TYPE, CHUNGS_COMPILER);
  std::printf("allocator: %s\n", allocator_description().c_str());
#ifdef CHUNGS_WITH_CUDA
  std::printf("cuda: built for sm %s, runtime %d\n", CHUNGS_CUDA_ARCHS, cuda::runtime_version());
  std::string why;
  auto devs = cuda::list_devices(&why);
  if (devs.empty()) std::printf("cuda devices: none (%s)\n", why.c_str());
  for (const auto& d : devs)
    std::printf("cuda device %d: %s, sm_%d%d, %d SMs, %.1f GiB (%.1f GiB free)\n", d.index, d.name.c_str(),
                d.major, d.minor, d.multiprocessors, d.total_memory / 1073741824.0,
                d.free_memory / 1073741824.0);
#else
  std::printf("cuda: not built (configure with CHUNGS_CUDA=ON or AUTO with nvcc present)\n");
#endif
}

struct InfoArgs {
  bool config = false;
  std::string config_file;
};

const Command info_cmd("info", "version, build options, CUDA devices; --config prints every setting",
                       [](CLI::App& app) -> Action {
                         auto args = std::make_shared<InfoArgs>();
                         app.add_flag(
                             "--config", args->config,
                             "print the configuration (defaults, or FILE applied over them) as YAML");
                         app.add_option("--config-file", args->config_file,
                                        "a YAML config to check and print")
                             ->check(CLI::ExistingFile);
                         return [args] {
                           if (args->config || !args->config_file.empty()) {
                             Config c = args->config_file.empty() ? Config{} : load_config(args->config_file);
                             std::fputs(config_to_yaml(c).c_str(), stdout);
                             return 0;
                           }
                           print_build();
                           return 0;
                         };
                       });

}  // namespace
}  // namespace chungs::app
