#include "chungs/store/io_stats.hpp"

#include <cstdio>

namespace chungs {

IoStats IoCounters::snapshot() const {
  IoStats s;
  s.loads = loads, s.saves = saves, s.removes = removes;
  s.bytes_read = bytes_read, s.bytes_written = bytes_written;
  s.load_ms = double(load_ns) * 1e-6, s.save_ms = double(save_ns) * 1e-6, s.wait_ms = double(wait_ns) * 1e-6;
  s.pool_loads = pool_loads, s.prefetch_hits = prefetch_hits, s.write_behind_hits = write_behind_hits;
  s.sync_loads = sync_loads, s.waits = waits;
  s.write_waits = write_waits, s.write_wait_ms = double(write_wait_ns) * 1e-6;
  s.evictions_clean = evictions_clean, s.evictions_dirty = evictions_dirty;
  s.evict_copy_ms = double(evict_copy_ns) * 1e-6, s.upload_ms = double(upload_ns) * 1e-6;
  s.evicting_ms = double(evicting_ns) * 1e-6, s.loading_ms = double(loading_ns) * 1e-6;
  s.take_ms = double(take_ns) * 1e-6, s.take_lock_ms = double(take_lock_ns) * 1e-6;
  s.read_ahead_full = read_ahead_full, s.read_ahead_no_room = read_ahead_no_room, s.reader_writes = reader_writes;
  s.barriers = barriers, s.synced_files = synced_files, s.barrier_ms = double(barrier_ns) * 1e-6;
  s.checkpoints = checkpoints, s.checkpoint_ms = double(checkpoint_ns) * 1e-6;
  s.checkpoints_behind = checkpoints_behind, s.checkpoint_behind_ms = double(checkpoint_behind_ns) * 1e-6;
  s.flush_gather_ms = double(flush_gather_ns) * 1e-6, s.flush_commit_ms = double(flush_commit_ns) * 1e-6;
  return s;
}

void IoCounters::reset() {
  for (auto* c :
       {&loads,       &saves,           &removes,         &bytes_read,    &bytes_written,     &load_ns,
        &save_ns,     &wait_ns,         &pool_loads,      &prefetch_hits, &write_behind_hits, &sync_loads,
        &waits,       &evictions_clean, &evictions_dirty, &barriers,      &synced_files,      &barrier_ns,
        &checkpoints, &checkpoint_ns,   &checkpoints_behind, &checkpoint_behind_ns, &write_waits, &write_wait_ns,
        &evict_copy_ns, &upload_ns, &evicting_ns, &loading_ns, &take_ns, &take_lock_ns,
        &read_ahead_full, &read_ahead_no_room, &reader_writes, &flush_gather_ns, &flush_commit_ns})
    c->store(0);
}

IoStats operator-(const IoStats& a, const IoStats& b) {
  IoStats d;
  const auto diff = [&](auto IoStats::*field) { d.*field = a.*field - b.*field; };
  for (auto f : {&IoStats::loads, &IoStats::saves, &IoStats::removes, &IoStats::bytes_read, &IoStats::bytes_written,
                 &IoStats::pool_loads, &IoStats::prefetch_hits, &IoStats::write_behind_hits, &IoStats::sync_loads,
                 &IoStats::waits, &IoStats::write_waits, &IoStats::evictions_clean, &IoStats::evictions_dirty,
                 &IoStats::barriers, &IoStats::synced_files, &IoStats::checkpoints, &IoStats::checkpoints_behind,
                 &IoStats::read_ahead_full, &IoStats::read_ahead_no_room, &IoStats::reader_writes})
    diff(f);
  for (auto f : {&IoStats::load_ms, &IoStats::save_ms, &IoStats::wait_ms, &IoStats::write_wait_ms,
                 &IoStats::evict_copy_ms, &IoStats::upload_ms, &IoStats::barrier_ms, &IoStats::checkpoint_ms,
                 &IoStats::checkpoint_behind_ms, &IoStats::evicting_ms, &IoStats::loading_ms, &IoStats::take_ms, &IoStats::take_lock_ms,
                 &IoStats::flush_gather_ms, &IoStats::flush_commit_ms})
    diff(f);
  return d;
}

std::string IoStats::summary() const {
  char buf[1024];
  std::snprintf(
      buf, sizeof buf,
      "chunk I/O: %llu loads (%.1f MB, %.2f ms avg), %llu saves (%.1f MB, %.2f ms avg), %llu removes; "
      "pool loads %llu: %llu prefetched, %llu from write-behind, %llu waited on disk (%.1f %%); "
      "%llu waits, %.1f ms (%llu for a full write queue, %.1f ms); evictions %llu clean, %llu dirty; %llu checkpoints, %.1f ms (%llu written "
      "behind, %.1f ms from start to commit), "
      "%llu barriers flushing %llu files, %.1f ms; pool copies %.1f ms out, %.1f ms in",
      (unsigned long long)loads, double(bytes_read) / 1e6, mean_load_ms(), (unsigned long long)saves,
      double(bytes_written) / 1e6, mean_save_ms(), (unsigned long long)removes,
      (unsigned long long)pool_loads, (unsigned long long)prefetch_hits,
      (unsigned long long)write_behind_hits, (unsigned long long)sync_loads, 100.0 * wait_fraction(),
      (unsigned long long)waits, wait_ms, (unsigned long long)write_waits, write_wait_ms,
      (unsigned long long)evictions_clean,
      (unsigned long long)evictions_dirty, (unsigned long long)checkpoints, checkpoint_ms,
      (unsigned long long)checkpoints_behind, checkpoint_behind_ms,
      (unsigned long long)barriers, (unsigned long long)synced_files, barrier_ms, evict_copy_ms, upload_ms);
  return buf;
}

}  // namespace chungs
