// Device memory in use on the current CUDA device (cudaMemGetInfo). Built only with CHUNGS_WITH_CUDA;
// no CUDA headers here.
#pragma once
#include <cstddef>

namespace chungs::cuda {

// False (outputs untouched) when the query fails, e.g. no device.
bool device_memory_info(size_t& free_bytes, size_t& total_bytes);

}  // namespace chungs::cuda
