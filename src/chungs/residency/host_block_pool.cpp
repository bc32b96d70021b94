#include "chungs/residency/host_block_pool.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <new>
#include <set>
#include <utility>

#include "chungs/common/log.hpp"

namespace chungs {

namespace {
// Blocks take whole units: small enough that a chunk of a few Gaussians wastes little, large enough
// that the free list stays short.
constexpr size_t kUnit = 1024;
size_t round_up(size_t bytes, size_t to) { return (bytes + to - 1) / to * to; }
size_t page_size() {
  const long p = ::sysconf(_SC_PAGESIZE);
  return p > 0 ? size_t(p) : 4096;
}
}  // namespace

namespace detail {

struct HostRegion {
  std::byte* base = nullptr;
  size_t size = 0;
  mutable std::mutex mutex;
  std::map<size_t, size_t> free;  // offset -> bytes, no two adjacent
  // The same ranges by (bytes, offset): the best fit is one lookup. A scan of `free` under this
  // lock, once per block, grew with the ranges that the queues' churn leaves.
  std::set<std::pair<size_t, size_t>> by_size;
  size_t used = 0, peak = 0;
  uint64_t heap_blocks = 0;
  bool resident = false;

  ~HostRegion() {
    if (base) ::munmap(base, size);
  }
  void add_free(size_t offset, size_t bytes) {
    free.emplace(offset, bytes);
    by_size.emplace(bytes, offset);
  }
  void erase_free(std::map<size_t, size_t>::iterator it) {
    by_size.erase({it->second, it->first});
    free.erase(it);
  }
  // Best fit: the smallest free range that holds `bytes`, lowest first among equals.
  bool take(size_t bytes, size_t& offset) {
    const auto best = by_size.lower_bound({bytes, 0});
    if (best == by_size.end()) return false;
    offset = best->second;
    const size_t left = best->first - bytes;
    erase_free(free.find(offset));
    if (left) add_free(offset + bytes, left);
    used += bytes;
    peak = std::max(peak, used);
    return true;
  }
  void give_back(size_t offset, size_t bytes) {
    used -= bytes;
    auto next = free.lower_bound(offset);
    if (next != free.begin()) {
      auto prev = std::prev(next);
      if (prev->first + prev->second == offset) {
        offset = prev->first;
        bytes += prev->second;
        erase_free(prev);
      }
    }
    if (next != free.end() && offset + bytes == next->first) {
      bytes += next->second;
      erase_free(next);
    }
    add_free(offset, bytes);
  }
};
}  // namespace detail

HostBlock::~HostBlock() {
  if (!region_) return;
  std::lock_guard lock(region_->mutex);
  region_->give_back(offset_, bytes_);
}

size_t HostBlockPool::block_bytes(size_t count) { return round_up(laid_out_bytes(count), kUnit); }

HostBlockPool::HostBlockPool(size_t bytes) : region_(std::make_shared<detail::HostRegion>()) {
  if (bytes == 0) return;
  const size_t size = round_up(bytes, std::max(page_size(), kUnit));
  // Address space only: pages become memory when first written (or by make_resident).
  void* p = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (p == MAP_FAILED) {
    log::warn("chunk I/O: could not map ", size >> 20, " MB for chunks in flight; they use the heap");
    return;
  }
  region_->base = static_cast<std::byte*>(p);
  region_->size = size;
  region_->add_free(0, size);
}

void HostBlockPool::make_resident() {
  detail::HostRegion& r = *region_;
  std::lock_guard lock(r.mutex);
  if (!r.base || r.resident) return;
#ifdef MADV_POPULATE_WRITE
  // Faults every page in as if written, without changing what blocks already hold.
  if (::madvise(r.base, r.size, MADV_POPULATE_WRITE) == 0) {
    r.resident = true;
    return;
  }
#endif
  // Older kernels: write the whole pages of the free ranges (blocks in use are their owners').
  const size_t page = page_size();
  for (const auto& [offset, bytes] : r.free) {
    volatile std::byte* p = r.base;
    for (size_t at = round_up(offset, page); at + page <= offset + bytes; at += page) p[at] = std::byte{0};
  }
  r.resident = true;
}

std::shared_ptr<HostBlock> HostBlockPool::make_in_pool(size_t count, int sh_degree) {
  auto block = std::make_shared<HostBlock>();
  block->arrays_.count = count;
  block->arrays_.sh_degree = sh_degree;
  if (count == 0) return block;
  const size_t bytes = block_bytes(count);
  size_t offset = 0;
  {
    std::lock_guard lock(region_->mutex);
    if (!region_->base || !region_->take(bytes, offset)) return nullptr;
  }
  block->region_ = region_;
  block->offset_ = offset;
  block->bytes_ = bytes;
  block->arrays_ = laid_out_arrays(region_->base + offset, count, sh_degree);
  return block;
}

std::shared_ptr<HostBlock> HostBlockPool::make(size_t count, int sh_degree) {
  if (auto block = make_in_pool(count, sh_degree)) return block;
  {
    std::lock_guard lock(region_->mutex);
    ++region_->heap_blocks;
  }
  auto block = std::make_shared<HostBlock>();
  const size_t bytes = laid_out_bytes(count);
  // The arrays start on 16-byte boundaries from a base that operator new[] aligns at least as much.
  static_assert(__STDCPP_DEFAULT_NEW_ALIGNMENT__ >= 16);
  block->heap_ = std::make_unique_for_overwrite<std::byte[]>(bytes);
  block->arrays_ = laid_out_arrays(block->heap_.get(), count, sh_degree);
  return block;
}

size_t HostBlockPool::capacity_bytes() const { return region_->size; }

size_t HostBlockPool::used_bytes() const {
  std::lock_guard lock(region_->mutex);
  return region_->used;
}

size_t HostBlockPool::peak_used_bytes() const {
  std::lock_guard lock(region_->mutex);
  return region_->peak;
}

uint64_t HostBlockPool::heap_blocks() const {
  std::lock_guard lock(region_->mutex);
  return region_->heap_blocks;
}

bool HostBlockPool::resident() const {
  std::lock_guard lock(region_->mutex);
  return region_->resident;
}

}  // namespace chungs
