// CUDA devices visible to this process (built only with CHUNGS_WITH_CUDA).
#pragma once
#include <string>
#include <vector>

namespace chungs::cuda {

struct DeviceInfo {
  int index = 0;
  std::string name;
  int major = 0, minor = 0;  // compute capability
  size_t total_memory = 0, free_memory = 0;
  int multiprocessors = 0;
};

// Empty with `why` set when no driver or device is present; never throws.
std::vector<DeviceInfo> list_devices(std::string* why = nullptr);
int runtime_version();

}  // namespace chungs::cuda
