#include "chungs/residency/residency.hpp"

#include <algorithm>
#include <unordered_set>
#include <utility>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/residency/parallel_save.hpp"

namespace chungs {

Residency::Residency(ChunkStore& store, GaussianPool& pool, const ResidencyConfig& config)
    : store_(store), pool_(pool), config_(config), budget_(config.budget_gaussians),
      host_blocks_(config.async_io ? in_flight_pool_bytes(config) : 0) {
  if (pool_.capacity() < budget_)
    fail("residency: the Gaussian pool holds ", pool_.capacity(), " Gaussians, less than the budget of ", budget_);
  if (pool_.used() != 0) fail("residency: the Gaussian pool must start empty (", pool_.used(), " slots in use)");
  config_.validate();
  for (const auto& [id, n] : store_.counts()) catalogue_[id] = n;
  io_ = std::make_unique<IoWorker>(store_, host_blocks_, config_.async_io, prefetch_max_gaussians(config_),
                                   write_behind_max_gaussians(config_), io_threads(config_));
}

Residency::~Residency() {
  try {
    if (config_.flush_on_close)
      flush();
    else
      finish_checkpoint();
  } catch (const std::exception& e) {
    log::error("residency: could not write the modified chunks on shutdown: ", e.what());
  }
}

Residency::Resident& Residency::resident_entry(ChunkId id, const char* what) {
  auto it = resident_.find(id);
  if (it == resident_.end()) fail("residency: ", what, " of ", chunk_name(id), ", which is not resident");
  return it->second;
}

bool Residency::is_pinned(ChunkId id) const {
  auto it = resident_.find(id);
  return it != resident_.end() && it->second.pins > 0;
}

bool Residency::is_dirty(ChunkId id) const {
  auto it = resident_.find(id);
  return it != resident_.end() && it->second.dirty;
}

const std::vector<uint32_t>& Residency::slots(ChunkId id) const {
  auto it = resident_.find(id);
  if (it == resident_.end()) fail("residency: slots of ", chunk_name(id), ", which is not resident");
  return it->second.slots;
}

void Residency::append_slots(std::span<const ChunkId> ids, std::vector<uint32_t>& out) const {
  for (ChunkId id : ids) {
    const auto& s = slots(id);
    out.insert(out.end(), s.begin(), s.end());
  }
}

size_t Residency::slot_count(std::span<const ChunkId> ids) const {
  size_t n = 0;
  for (ChunkId id : ids) n += slots(id).size();
  return n;
}

void Residency::write_slots(std::span<const ChunkId> ids, std::span<uint32_t> out) const {
  size_t at = 0;
  for (ChunkId id : ids) {
    const std::vector<uint32_t>& s = slots(id);
    if (s.size() > out.size() - at) fail("residency: room for ", out.size(), " slots is too small for ", ids.size(), " chunks");
    std::copy(s.begin(), s.end(), out.begin() + std::ptrdiff_t(at));
    at += s.size();
  }
  if (at != out.size()) fail("residency: room for ", out.size(), " slots given for ", at);
}

std::vector<ChunkId> Residency::resident_chunks() const {
  std::vector<ChunkId> out;
  out.reserve(resident_.size());
  for (const auto& [id, e] : resident_) out.push_back(id);
  std::sort(out.begin(), out.end());
  return out;
}

uint64_t Residency::count(ChunkId id) const {
  auto it = catalogue_.find(id);
  return it == catalogue_.end() ? 0 : it->second;
}

void Residency::touch(Resident& r, ChunkId) { lru_.splice(lru_.begin(), lru_, r.lru); }

void Residency::check_budget_invariant() const {
  if (resident_gaussians_ > budget_)
    fail("residency: internal error: ", resident_gaussians_, " Gaussians resident, budget ", budget_);
}

std::string Residency::over_budget_message(uint64_t pinned, size_t chunks) const {
  return cat("residency: pinning ", chunks, " chunks would hold ", pinned, " Gaussians (", pinned_gaussians_,
             " already pinned), ", pinned - budget_, " over the budget of ", budget_,
             "; nothing was loaded. Pin fewer chunks (shorter far plane, smaller chunks) or raise the budget.");
}

PinResult Residency::pin(std::span<const ChunkId> ids, bool recent) {
  PinResult r;
  r.budget = budget_;
  std::vector<ChunkId> want(ids.begin(), ids.end());
  std::sort(want.begin(), want.end());
  want.erase(std::unique(want.begin(), want.end()), want.end());
  std::erase_if(want, [&](ChunkId id) {
    if (catalogue_.count(id)) return false;
    r.unknown.push_back(id);
    return true;
  });
  uint64_t newly_pinned = 0, missing = 0;
  for (ChunkId id : want) {
    if (!is_pinned(id)) newly_pinned += count(id);
    if (!is_resident(id)) missing += count(id);
  }
  const uint64_t total = pinned_gaussians_ + newly_pinned;
  if (total > budget_) {
    r.ok = false;
    r.pinned_gaussians = total;
    r.over_budget = total - budget_;
    r.message = over_budget_message(total, want.size());
    log::warn(r.message);
    return r;
  }
  copy_out_many(want);  // a pinned chunk may change
  if (!make_room(missing, want, &r.evicted))
    fail("residency: internal error: no room for ", missing, " Gaussians although the pinned set fits");
  std::vector<ChunkId> absent;
  for (ChunkId id : want)
    if (!is_resident(id)) absent.push_back(id);
  load_many(absent);
  r.loaded = absent.size();
  for (ChunkId id : want) {
    Resident& e = resident_.at(id);
    if (e.pins++ == 0) pinned_gaussians_ += e.slots.size();
    if (recent) touch(e, id);
  }
  r.pinned_gaussians = pinned_gaussians_;
  check_budget_invariant();
  return r;
}

void Residency::unpin(std::span<const ChunkId> ids) {
  std::unordered_map<ChunkId, int> times;
  for (ChunkId id : ids) ++times[id];
  for (const auto& [id, n] : times)  // check all first: a failed unpin changes nothing
    if (resident_entry(id, "unpin").pins < n) fail("residency: unpin of ", chunk_name(id), ", which is not pinned");
  for (const auto& [id, n] : times) {
    Resident& e = resident_.at(id);
    e.pins -= n;
    if (e.pins == 0) pinned_gaussians_ -= e.slots.size();
  }
}

void Residency::unpin_all() {
  for (auto& [id, e] : resident_) e.pins = 0;
  pinned_gaussians_ = 0;
}

bool Residency::make_room(uint64_t extra, std::span<const ChunkId> keep, size_t* evicted) {
  if (resident_gaussians_ + extra <= budget_) return true;
  const uint64_t shortfall = resident_gaussians_ + extra - budget_;
  const uint64_t target = shortfall + uint64_t(config_.eviction_hysteresis * double(budget_));
  const std::unordered_set<ChunkId> kept(keep.begin(), keep.end());
  // Oldest first; stop as soon as the target is reached, so as few chunks as possible go. Chunks
  // the next steps need (the prefetch hint) go only when the rest cannot make room, and then the
  // one needed last first: under a 100 k budget on a 2 km street, evicting by age alone threw out
  // the chunks of the very next pick, and two thirds of the chunk loads waited on the disk.
  std::vector<ChunkId> victims;
  std::vector<std::pair<size_t, ChunkId>> hinted;  // (place in the hint, chunk)
  uint64_t freed = 0;
  for (auto it = lru_.rbegin(); it != lru_.rend() && freed < target; ++it) {
    const Resident& e = resident_.at(*it);
    if (e.pins > 0 || kept.count(*it)) continue;
    if (const auto h = hint_rank_.find(*it); h != hint_rank_.end()) {
      hinted.emplace_back(h->second, *it);
      continue;
    }
    victims.push_back(*it);
    freed += e.slots.size();
  }
  bool hinted_evicted = false;
  if (freed < shortfall) {
    std::sort(hinted.begin(), hinted.end(), std::greater<>());
    for (size_t i = 0; i < hinted.size() && freed < shortfall; ++i) {
      victims.push_back(hinted[i].second);
      freed += resident_.at(hinted[i].second).slots.size();
      hinted_evicted = true;
    }
  }
  if (freed < shortfall) return false;
  evict_entries(victims);
  if (evicted) *evicted += victims.size();
  if (hinted_evicted) queue_reads_ahead();  // they are needed again soon: read them back behind the step
  return true;
}

void Residency::load_many(std::span<const ChunkId> ids) {
  ScopedTimer all(store_.counters().loading_ns);
  // Taken from the I/O threads and scattered into the pool a portion at a time: one acquisition of
  // their lock and one transfer each (on a GPU one upload per portion instead of one per chunk; a
  // refinement step under 300 k loads ~60).
  const size_t portion = transfer_portion();
  for (size_t k = 0; k < ids.size();) {
    size_t end = k, gaussians = 0;
    for (; end < ids.size() && (end == k || gaussians < portion); ++end) gaussians += count(ids[end]);
    const std::span<const ChunkId> part = ids.subspan(k, end - k);
    const std::vector<std::shared_ptr<const HostBlock>> blocks = take_blocks(part);
    std::vector<ConstBlockArrays> arrays;
    for (const auto& b : blocks) arrays.push_back(b->arrays());
    const std::vector<uint32_t> slots = pool_.allocate(gaussians);  // the blocks' counts were checked
    try {
      ScopedTimer t(store_.counters().upload_ns);
      pool_.scatter(arrays, slots);
    } catch (...) {
      pool_.release(slots);
      throw;
    }
    size_t first = 0;
    for (size_t i = 0; i < blocks.size(); ++i) {
      const size_t n = blocks[i]->size();
      Resident e;
      e.slots.assign(slots.begin() + ptrdiff_t(first), slots.begin() + ptrdiff_t(first + n));
      first += n;
      lru_.push_front(part[i]);
      e.lru = lru_.begin();
      resident_.emplace(part[i], std::move(e));
      resident_gaussians_ += n;
    }
    peak_resident_ = std::max(peak_resident_, resident_gaussians_);
    k = end;
  }
}

std::vector<std::shared_ptr<const HostBlock>> Residency::take_blocks(std::span<const ChunkId> ids) {
  std::vector<std::shared_ptr<const HostBlock>> blocks(ids.size());
  std::vector<ChunkId> held;  // chunks with Gaussians; an empty one needs no I/O
  for (size_t i = 0; i < ids.size(); ++i) {
    if (count(ids[i]) > 0)
      held.push_back(ids[i]);
    else
      blocks[i] = std::make_shared<const HostBlock>();
  }
  std::vector<IoWorker::Source> sources;
  std::vector<IoWorker::Block> taken;
  {
    ScopedTimer t(store_.counters().take_ns);
    taken = io_->take_many(held, sources);
  }
  IoCounters& c = store_.counters();
  for (size_t i = 0, h = 0; i < ids.size(); ++i) {
    if (blocks[i]) continue;
    const uint64_t n = count(ids[i]);
    if (taken[h]->size() != n)
      fail("residency: ", chunk_name(ids[i]), " has ", taken[h]->size(), " Gaussians in ",
           store_.chunk_path(ids[i]).string(), " but the map lists ", n);
    c.pool_loads++;
    if (sources[h] == IoWorker::Source::Prefetched) c.prefetch_hits++;
    if (sources[h] == IoWorker::Source::WriteBehind) c.write_behind_hits++;
    if (sources[h] == IoWorker::Source::Disk) c.sync_loads++;
    blocks[i] = std::move(taken[h++]);
  }
  return blocks;
}

void Residency::evict_entries(std::span<const ChunkId> ids) {
  ScopedTimer all(store_.counters().evicting_ns);
  // Modified chunks leave the pool a portion at a time, one gather each: on a GPU one round trip per
  // portion instead of one per chunk (a refinement step under 300 k evicts ~70). Portions, not all at
  // once, so that the copies made wait for the write queue's room as they did one by one.
  const size_t portion = transfer_portion();
  for (size_t k = 0; k < ids.size();) {
    std::vector<ChunkId> for_checkpoint, others;
    size_t end = k, gathered = 0;
    for (; end < ids.size() && (end == k || gathered < portion); ++end) {
      const Resident& e = resident_entry(ids[end], "evict");
      if (!e.dirty) continue;
      (checkpoint_ && checkpoint_todo_.count(ids[end]) ? for_checkpoint : others).push_back(ids[end]);
      gathered += e.slots.size();
    }
    std::unordered_map<ChunkId, std::shared_ptr<const HostBlock>> blocks;
    // Still wanted by the checkpoint in flight: one copy serves both (all of them still to copy, so
    // copy_out_many hands them back in this order).
    std::vector<std::shared_ptr<const HostBlock>> copied = copy_out_many(for_checkpoint);
    for (size_t i = 0; i < copied.size(); ++i) blocks.emplace(for_checkpoint[i], std::move(copied[i]));
    if (!others.empty()) {
      ScopedTimer t(store_.counters().evict_copy_ns);
      std::vector<std::shared_ptr<const HostBlock>> out = gather_chunks(others);
      for (size_t i = 0; i < out.size(); ++i) blocks.emplace(others[i], std::move(out[i]));
    }
    for (; k < end; ++k) {
      const auto b = blocks.find(ids[k]);
      evict_one(ids[k], b == blocks.end() ? nullptr : std::move(b->second));
    }
  }
}

void Residency::evict_one(ChunkId id, std::shared_ptr<const HostBlock> block) {
  Resident& e = resident_.at(id);
  const size_t n = e.slots.size();
  checkpoint_clean_.erase(id);  // written behind now, or already clean
  if (e.dirty) {
    if (!block) fail("residency: internal error: ", chunk_name(id), " is modified but was not copied out");
    io_->write_behind(id, std::move(block));  // throws before anything changed here
    store_.counters().evictions_dirty++;
  } else {
    store_.counters().evictions_clean++;
  }
  pool_.release(e.slots);
  lru_.erase(e.lru);
  resident_.erase(id);
  resident_gaussians_ -= n;
  if (n == 0) {  // an emptied chunk leaves the map once its removal is queued
    catalogue_.erase(id);
    ++catalogue_version_;
  }
}

void Residency::remove_slots(ChunkId id, std::span<const uint32_t> slots) {
  Resident& e = resident_entry(id, "remove_slots");
  copy_out(id);
  std::vector<uint32_t> gone(slots.begin(), slots.end());
  std::sort(gone.begin(), gone.end());
  if (std::adjacent_find(gone.begin(), gone.end()) != gone.end())
    fail("residency: remove_slots of ", chunk_name(id), " lists a slot twice");
  std::vector<uint32_t> kept;
  kept.reserve(e.slots.size());
  for (uint32_t s : e.slots)
    if (!std::binary_search(gone.begin(), gone.end(), s)) kept.push_back(s);
  if (e.slots.size() - kept.size() != gone.size())
    fail("residency: remove_slots lists slots that do not belong to ", chunk_name(id));
  e.slots = std::move(kept);
  drop_slots(id, gone);
}

size_t Residency::remove_written_slots(std::span<const ChunkId> ids, std::span<const uint32_t> positions) {
  if (positions.empty()) return 0;
  for (size_t i = 1; i < positions.size(); ++i)
    if (positions[i] <= positions[i - 1])
      fail("residency: positions to remove are not strictly ascending (", positions[i - 1], " then ",
           positions[i], ")");
  std::vector<ChunkId> sorted(ids.begin(), ids.end());
  std::sort(sorted.begin(), sorted.end());
  if (const auto twice = std::adjacent_find(sorted.begin(), sorted.end()); twice != sorted.end())
    fail("residency: remove_written_slots lists ", chunk_name(*twice), " twice");
  if (const size_t written = slot_count(ids); positions.back() >= written)
    fail("residency: position ", positions.back(), " is past the ", written, " slots written");
  size_t at = 0, start = 0;  // next position; where the chunk's slots begin in the written list
  std::vector<uint32_t> gone;
  for (ChunkId id : ids) {
    if (at == positions.size()) break;
    Resident& e = resident_entry(id, "remove_written_slots");
    const size_t end = start + e.slots.size();
    if (positions[at] >= end) {
      start = end;
      continue;
    }
    copy_out(id);
    // Kept in their order, compacted in place; the gone ones freed in slot order as remove_slots frees them,
    // so that the pool reuses slots as it did when pruning looked the slots up.
    // The runs between gone entries move down whole (a memmove each), not entry by entry.
    gone.clear();
    std::vector<uint32_t>& s = e.slots;
    size_t write = positions[at] - start, read = write;
    for (; at < positions.size() && positions[at] < end; ++at) {
      const size_t p = positions[at] - start;
      std::copy(s.begin() + std::ptrdiff_t(read), s.begin() + std::ptrdiff_t(p),
                s.begin() + std::ptrdiff_t(write));
      write += p - read;
      gone.push_back(s[p]);  // write <= read <= p: the copy above ends before p
      read = p + 1;
    }
    std::copy(s.begin() + std::ptrdiff_t(read), s.end(), s.begin() + std::ptrdiff_t(write));
    s.resize(write + (s.size() - read));
    std::sort(gone.begin(), gone.end());
    drop_slots(id, gone);
    start = end;
  }
  return positions.size();
}

void Residency::drop_slots(ChunkId id, std::span<const uint32_t> gone) {
  Resident& e = resident_.at(id);
  pool_.release(gone);
  e.dirty = true;
  checkpoint_clean_.erase(id);
  resident_gaussians_ -= gone.size();
  catalogue_[id] -= gone.size();
  if (e.pins > 0) pinned_gaussians_ -= gone.size();
}

void Residency::mark_dirty(ChunkId id) {
  resident_entry(id, "mark_dirty").dirty = true;
  checkpoint_clean_.erase(id);
}

void Residency::mark_dirty(std::span<const ChunkId> ids) {
  for (ChunkId id : ids) mark_dirty(id);
}

void Residency::prefetch(std::span<const ChunkId> ids) {
  hint_.clear();
  hint_rank_.clear();
  for (ChunkId id : ids)  // a chunk named twice counts where it is first needed
    if (hint_rank_.emplace(id, hint_.size()).second) hint_.push_back(id);
  queue_reads_ahead();
}

void Residency::queue_reads_ahead() {
  std::vector<std::pair<ChunkId, uint64_t>> list;
  for (ChunkId id : hint_)
    if (!is_resident(id) && count(id) > 0) list.emplace_back(id, count(id));
  io_->prefetch(list);
}

void Residency::evict(ChunkId id) {
  if (resident_entry(id, "evict").pins > 0) fail("residency: cannot evict ", chunk_name(id), ": it is pinned");
  const ChunkId one[] = {id};
  evict_entries(one);
}

void Residency::evict_all_unpinned() {
  std::vector<ChunkId> victims;
  for (const auto& [id, e] : resident_)
    if (e.pins == 0) victims.push_back(id);
  evict_entries(victims);
}

void Residency::flush() {
  finish_checkpoint();
  ScopedTimer t(store_.counters().checkpoint_ns);  // the caller is blocked for all of it
  store_.counters().checkpoints++;
  if (config_.async_io && config_.flush_threads > 1) {
    // Queued writes first: a resident chunk may have an older version still queued, which must
    // not land after the one written here.
    io_->drain();
    std::vector<ChunkId> dirty;
    for (const auto& [id, e] : resident_)
      if (e.dirty) dirty.push_back(id);
    // One gather per portion of chunks, not per chunk: from a GPU pool each gather is a round trip,
    // and a chunk of ~200 Gaussians made the final checkpoint of a 4,000-chunk map wait on them.
    const size_t portion_limit = transfer_portion();
    std::vector<std::shared_ptr<const HostBlock>> portion;
    size_t portion_begin = 0, portion_end = 0;
    auto produce = [&](size_t k, GaussianBlock& b) {
      if (k == portion_end) {
        size_t n = 0;
        for (portion_begin = k; portion_end < dirty.size() && (portion_end == k || n < portion_limit); ++portion_end)
          n += resident_.at(dirty[portion_end]).slots.size();
        ScopedTimer gathering(store_.counters().flush_gather_ns);
        portion = gather_chunks(std::span(dirty).subspan(portion_begin, portion_end - portion_begin));
      }
      const HostBlock& h = *portion[k - portion_begin];
      b.sh_degree = h.sh_degree();
      b.resize(h.size());
      copy_gaussians(h.arrays(), 0, h.size(), block_arrays(b));
    };
    save_chunks_in_parallel(store_, dirty, produce, config_.flush_threads);
    for (ChunkId id : dirty) resident_.at(id).dirty = false;
  } else {
    for (auto& [id, e] : resident_) {
      if (!e.dirty) continue;
      std::shared_ptr<HostBlock> block = host_blocks_.make(e.slots.size(), pool_.sh_degree());
      pool_.gather(e.slots, block->arrays());
      io_->write_behind(id, std::move(block));
      e.dirty = false;
    }
    io_->drain();
  }
  ScopedTimer committing(store_.counters().flush_commit_ns);
  store_.commit();
}

bool Residency::set_budget(size_t gaussians) {
  if (gaussians > pool_.capacity())
    fail("residency: budget ", gaussians, " exceeds the pool capacity of ", pool_.capacity());
  if (pinned_gaussians_ > gaussians) {
    log::warn("residency: cannot lower the budget to ", gaussians, ": ", pinned_gaussians_, " Gaussians are pinned");
    return false;
  }
  budget_ = gaussians;
  if (!make_room(0, {}, nullptr)) fail("residency: internal error: cannot shrink to the new budget");
  return true;
}

}  // namespace chungs
