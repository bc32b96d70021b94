// Residency's checkpoints written behind the caller (residency.hpp, begin_checkpoint).
#include <algorithm>
#include <utility>

#include "chungs/residency/residency.hpp"

namespace chungs {

namespace {
double ns_since(std::chrono::steady_clock::time_point t) {
  return double(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t).count());
}
}  // namespace

size_t checkpoint_memory_limit(size_t budget) { return std::max<size_t>(budget / 32, 10'000); }

size_t Residency::checkpoint_memory_limit() const { return chungs::checkpoint_memory_limit(budget_); }

std::vector<std::shared_ptr<const HostBlock>> Residency::gather_chunks(std::span<const ChunkId> ids) {
  std::vector<std::shared_ptr<const HostBlock>> out;
  out.reserve(ids.size());
  const size_t portion_limit = transfer_portion();
  std::vector<uint32_t> slots;
  std::vector<BlockArrays> arrays;
  for (size_t k = 0; k < ids.size();) {
    slots.clear();
    arrays.clear();
    for (; k < ids.size() && (arrays.empty() || slots.size() < portion_limit); ++k) {
      const auto& s = resident_.at(ids[k]).slots;
      std::shared_ptr<HostBlock> block = host_blocks_.make(s.size(), pool_.sh_degree());
      slots.insert(slots.end(), s.begin(), s.end());
      arrays.push_back(block->arrays());
      out.push_back(std::move(block));
    }
    pool_.gather(slots, arrays);
  }
  return out;
}

std::vector<ChunkId> Residency::next_portion(size_t gaussians) const {
  std::vector<ChunkId> out;
  size_t n = 0;
  for (auto it = checkpoint_todo_.begin(); it != checkpoint_todo_.end() && (out.empty() || n < gaussians); ++it) {
    out.push_back(*it);
    n += resident_.at(*it).slots.size() + 1;
  }
  return out;
}

void Residency::begin_checkpoint(std::function<void()> before_commit, std::function<void()> after_commit) {
  finish_checkpoint();
  IoCounters& c = store_.counters();
  ScopedTimer t(c.checkpoint_ns);
  c.checkpoints++;
  c.checkpoints_behind++;
  checkpoint_started_ = std::chrono::steady_clock::now();
  io_->drain();  // evictions queued so far belong to the checkpoint's map
  checkpoint_ = std::make_unique<CheckpointWriter>(store_, config_.checkpoint_threads);
  checkpoint_before_ = std::move(before_commit);
  checkpoint_after_ = std::move(after_commit);
  checkpoint_todo_.clear();
  checkpoint_clean_.clear();
  for (const auto& [id, e] : resident_)
    if (e.dirty) checkpoint_todo_.insert(id);
  if (checkpoint_todo_.empty()) checkpoint_->close(std::move(checkpoint_before_), std::move(checkpoint_after_));
}

std::shared_ptr<const HostBlock> Residency::copy_out(ChunkId id) {
  const ChunkId one[] = {id};
  std::vector<std::shared_ptr<const HostBlock>> copied = copy_out_many(one);
  return copied.empty() ? nullptr : std::move(copied.front());
}

std::vector<std::shared_ptr<const HostBlock>> Residency::copy_out_many(std::span<const ChunkId> ids) {
  std::vector<std::shared_ptr<const HostBlock>> copied;
  if (!checkpoint_) return copied;
  std::vector<ChunkId> todo;
  for (ChunkId id : ids)
    if (checkpoint_todo_.erase(id)) todo.push_back(id);
  if (todo.empty()) return copied;
  ScopedTimer t(store_.counters().checkpoint_ns);
  // Copies made because a step is about to change or evict a chunk join the writers' queue too, and
  // once written behind that queue alone holds them: without this wait a burst of pruning or eviction
  // during a checkpoint queued far more than the in-flight pool holds, and the rest went to the heap
  // (a 10 km drive's host RSS stepped up 5 % at one checkpoint). The checkpoint's own portions come
  // only below the limit anyway.
  checkpoint_->wait_below(checkpoint_memory_limit());
  std::vector<std::shared_ptr<const HostBlock>> blocks = gather_chunks(todo);
  for (size_t k = 0; k < todo.size(); ++k) {
    checkpoint_->put(todo[k], blocks[k]);
    checkpoint_clean_.insert(todo[k]);
    copied.push_back(std::move(blocks[k]));
  }
  if (checkpoint_todo_.empty()) checkpoint_->close(std::move(checkpoint_before_), std::move(checkpoint_after_));
  return copied;
}

void Residency::advance_checkpoint() {
  if (!checkpoint_) return;
  if (!checkpoint_todo_.empty()) {
    // A portion per call spreads the gathers over many steps; the bound keeps host memory flat.
    const size_t limit = checkpoint_memory_limit();
    if (checkpoint_->queued_gaussians() < limit) copy_out_many(next_portion(transfer_portion()));
  }
  if (checkpoint_->finished()) {
    store_.counters().checkpoint_behind_ns += uint64_t(ns_since(checkpoint_started_));
    auto done = std::move(checkpoint_);
    checkpoint_todo_.clear();
    try {
      done->rethrow();
    } catch (...) {
      checkpoint_clean_.clear();
      throw;
    }
    adopt_checkpoint();
  }
}

void Residency::adopt_checkpoint() {
  for (ChunkId id : checkpoint_clean_) {
    const auto it = resident_.find(id);
    if (it != resident_.end() && store_.adopt_committed(id)) it->second.dirty = false;
  }
  checkpoint_clean_.clear();
}

void Residency::finish_checkpoint() {
  if (!checkpoint_) return;
  {
    ScopedTimer t(store_.counters().checkpoint_ns);
    try {
      while (!checkpoint_todo_.empty()) copy_out_many(next_portion(transfer_portion()));  // each waits below the limit
      checkpoint_->wait();
    } catch (...) {
      checkpoint_.reset();
      checkpoint_todo_.clear();
      checkpoint_clean_.clear();
      throw;
    }
  }
  store_.counters().checkpoint_behind_ns += uint64_t(ns_since(checkpoint_started_));
  checkpoint_.reset();
  adopt_checkpoint();
}

}  // namespace chungs
