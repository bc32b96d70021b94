// ResidencyConfig: its checks, and the sizes it leaves at 0 (automatic) as Residency uses them.
#include <algorithm>
#include <cstdint>
#include <thread>

#include "chungs/common/error.hpp"
#include "chungs/residency/residency.hpp"

namespace chungs {

// Both queues hold at least one large view of a street (100-136 k Gaussians at 620x188 on the 2 km street):
// the refinement's visit to a place evicts and reads about that much at its first step. With 65,536 read
// ahead and 1/8 of a 300 k budget queued, the 300 k cell alone on an H200 waited 6.1-9.2 % of its run on
// chunk I/O; with 160 k and 150 k, 4.0 % twice (bench/README.md, issue 19). With 1/32 of a 100 k budget
// (10 k) read ahead, the reads for the next steps pushed each other out before use, and 85 % of a 2 km
// drive's chunk loads waited on the disk.
namespace {
constexpr size_t kViewFloor = 160'000;
}  // namespace

size_t prefetch_max_gaussians(const ResidencyConfig& c) {
  if (c.prefetch_max_gaussians) return c.prefetch_max_gaussians;
  return std::max(c.budget_gaussians / 32, std::min(c.budget_gaussians, kViewFloor));
}
// Half the budget at most below 1/8 of it: the queue's memory stays in proportion to the budget.
size_t write_behind_max_gaussians(const ResidencyConfig& c) {
  if (c.write_behind_max_gaussians) return c.write_behind_max_gaussians;
  return std::max({c.budget_gaussians / 8, std::min(c.budget_gaussians / 2, kViewFloor), size_t(10'000)});
}
// One per core, 4 to 16: they mostly wait on the file system. The 300 k cell alone on a 16-core H200
// host waited 7.9 % of its run on chunk I/O with 4 (a full write queue, once the reads no longer
// waited), 2.4-5.1 % with 8 and 2.5-3.3 % with 16 (bench/README.md, issue 19).
int io_threads(const ResidencyConfig& c) {
  if (c.write_behind_threads > 0) return c.write_behind_threads;
  return std::clamp(int(std::thread::hardware_concurrency()), 4, 16);
}

void ResidencyConfig::validate() const {
  constexpr size_t kMaxGaussians = size_t(1) << 34;  // far beyond any GPU or host memory
  if (budget_gaussians < 1 || budget_gaussians > kMaxGaussians)
    fail("residency: budget_gaussians must be in [1, ", kMaxGaussians, "], got ", budget_gaussians);
  if (!(eviction_hysteresis >= 0 && eviction_hysteresis < 1))
    fail("residency: eviction_hysteresis must be in [0, 1), got ", eviction_hysteresis);
  if (prefetch_max_gaussians > kMaxGaussians || write_behind_max_gaussians > kMaxGaussians)
    fail("residency: prefetch_max_gaussians and write_behind_max_gaussians must be at most ", kMaxGaussians);
  if (flush_threads < 1 || flush_threads > 256) fail("residency: flush_threads must be in [1, 256], got ", flush_threads);
  if (write_behind_threads < 0 || write_behind_threads > 256)
    fail("residency: write_behind_threads must be in [0, 256] (0: one per core, 4 to 16), got ", write_behind_threads);
  if (checkpoint_threads < 1 || checkpoint_threads > 256)
    fail("residency: checkpoint_threads must be in [1, 256], got ", checkpoint_threads);
  if (!(pool_headroom >= 0 && pool_headroom <= 4)) fail("residency: pool_headroom must be in [0, 4], got ", pool_headroom);
  // The pool holds the budget and its headroom in slots of 32-bit indices: a budget beyond them was
  // accepted here and refused mid-start by the pool, naming neither the budget nor the headroom.
  const double slots = double(budget_gaussians) * (1 + pool_headroom);
  if (slots > double(UINT32_MAX))
    fail("residency: budget_gaussians ", budget_gaussians, " with pool_headroom ", pool_headroom, " needs ",
         size_t(slots), " pool slots, beyond the ", UINT32_MAX, " that 32-bit slot indices address (at most ",
         size_t(double(UINT32_MAX) / (1 + pool_headroom)), " Gaussians)");
}

size_t in_flight_max_gaussians(const ResidencyConfig& config) {
  return prefetch_max_gaussians(config) + write_behind_max_gaussians(config) + checkpoint_memory_limit(config.budget_gaussians);
}

size_t in_flight_pool_bytes(const ResidencyConfig& config) {
  // An eighth more than the Gaussians take: each block rounds up to whole units of the pool, and a
  // queue may pass its limit by the block that fills it.
  const size_t bytes = in_flight_max_gaussians(config) * kBlockBytesPerGaussian;
  return bytes + bytes / 8;
}

}  // namespace chungs
