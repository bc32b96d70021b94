// Residency: which chunks live in the GaussianPool, under a budget counted in Gaussians.
//
// Before a step the caller pins the chunks it needs. Missing ones are loaded; when they do not
// fit, the least recently used unpinned chunks are evicted, oldest first, stopping as soon as the
// room (plus a hysteresis margin, so the next step does not evict again) is free. A chunk not
// modified since load is dropped without a write; a modified one is handed to the write-behind
// queue before its slots are reused, and until it is on disk any load gets the queued copy.
// If the pinned set alone exceeds the budget, pin() changes nothing and says by how much.
//
// Residency keeps the catalogue of every chunk of the map (resident or not) with its count: the
// culler works over catalogue() and the store learns of changes when chunks are written.
// Not thread-safe: one thread (the mapper) drives it; the I/O thread is internal.
#pragma once
#include <algorithm>
#include <chrono>
#include <functional>
#include <list>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "chungs/residency/checkpoint_writer.hpp"
#include "chungs/residency/gaussian_pool.hpp"
#include "chungs/residency/host_block_pool.hpp"
#include "chungs/residency/io_worker.hpp"
#include "chungs/store/chunk_store.hpp"

namespace chungs {

struct ResidencyConfig {
  size_t budget_gaussians = 1'500'000;  // the paper's VRAM budget
  double eviction_hysteresis = 0.05;    // evict this fraction of the budget beyond the shortfall
  bool async_io = true;                 // background prefetch and write-behind
  // Host memory for chunks in flight, in Gaussians (~0.7 kB each with Adam state), so that host
  // memory stays in proportion to the budget, not the map. 0: automatic. Read-ahead only needs the
  // chunks of the next few steps, and it fills only once the drive comes back to evicted chunks: a
  // larger one raises the resident set minutes after the budget is reached (unless the pool is made
  // resident at the start, see in_flight_blocks). It is 1/32 of the budget, but at least 160 000 (or
  // the budget, if smaller), so that a large view fits. Write-behind (1/8 of the budget, but at least
  // 160 000 or half the budget, and at least 10 000) must take one eviction's burst (the hysteresis,
  // 1/20) and a refinement visit's switch to another place (about a view).
  size_t prefetch_max_gaussians = 0;      // read ahead into host memory at most this many
  size_t write_behind_max_gaussians = 0;  // queued for writing before eviction waits
  int flush_threads = 8;  // threads writing the modified resident chunks at flush() (async_io only)
  // Chunk I/O threads behind the caller (async_io only): each reads ahead and writes evicted modified
  // chunks. One writer kept a refinement that mixes places waiting on its queue (a dirty eviction for
  // nearly every load), one reader left most of its loads to wait. 0: one per core, 4 to 16.
  int write_behind_threads = 0;
  int checkpoint_threads = 4;  // threads writing a checkpoint behind the caller (begin_checkpoint)
  // Pool slots beyond the budget (a fraction of it), used only while a loop correction raises the
  // budget so that all affected chunks are moved in one batch.
  double pool_headroom = 0.25;
  // false: the destructor writes nothing (only a checkpoint in flight is finished), for a caller
  // that commits consistent states itself, e.g. the mapper's checkpoints with their keyframe list.
  bool flush_on_close = true;
  void validate() const;  // throws Error naming the key out of range
};

// The read-ahead's and the write queue's limits in Gaussians, and the chunk I/O threads, for a config
// (the automatic ones where it says 0; residency_config.cpp says why they are what they are).
size_t prefetch_max_gaussians(const ResidencyConfig& config);
size_t write_behind_max_gaussians(const ResidencyConfig& config);
int io_threads(const ResidencyConfig& config);
// Host memory the chunks in flight may hold at once, in Gaussians: read-ahead, queued writes and a
// checkpoint's copies at their limits (the automatic ones where the config says 0).
size_t in_flight_max_gaussians(const ResidencyConfig& config);
// Bytes of the pool for chunks in flight (host_block_pool.hpp) that Residency maps for a config:
// room for in_flight_max_gaussians plus what the blocks' rounding takes.
size_t in_flight_pool_bytes(const ResidencyConfig& config);
// Gaussians a checkpoint copies out ahead of its writers at most, for a budget.
size_t checkpoint_memory_limit(size_t budget);

struct PinResult {
  bool ok = true;
  uint64_t pinned_gaussians = 0;  // in all pinned chunks (after the call, or as requested if !ok)
  uint64_t budget = 0;
  uint64_t over_budget = 0;       // by how many Gaussians the request exceeds the budget (!ok)
  size_t loaded = 0, evicted = 0; // chunks moved by this call
  std::vector<ChunkId> unknown;   // requested ids that are not in the map (skipped)
  std::string message;            // why !ok, in words
};

// One chunk's new Gaussians for Residency::add_many (the block must outlive the call).
struct ChunkAddition {
  ChunkId id = 0;
  const GaussianBlock* block = nullptr;
};

class Residency {
 public:
  // The pool must hold at least the budget; the pool is used only through this object.
  Residency(ChunkStore& store, GaussianPool& pool, const ResidencyConfig& config = {});
  ~Residency();  // flush() (see flush_on_close); errors are logged
  Residency(const Residency&) = delete;
  Residency& operator=(const Residency&) = delete;

  // Makes the chunks resident and pins them (pins nest). Unknown ids are skipped and listed.
  // recent = false leaves their place in the LRU order as it is: a use that should not keep chunks
  // resident in place of those the next steps need (a partial view's step).
  PinResult pin(std::span<const ChunkId> ids, bool recent = true);
  void unpin(std::span<const ChunkId> ids);  // throws on a chunk that is not pinned
  void unpin_all();

  // Appends Gaussians to a chunk, creating it if new; the chunk becomes resident (not pinned).
  // When they cannot fit beside the pinned chunks nothing is added and the result says why (the
  // caller decides whether that is worth a warning: a mapper's log would repeat it every keyframe).
  PinResult add(ChunkId id, const GaussianBlock& block);
  // add() of several chunks, one result each in their order (a chunk named twice gets both blocks).
  // When they fit together they are made room for, read and uploaded at once (the eviction count on
  // the first result); otherwise each is added or refused on its own, in order, as add() would.
  std::vector<PinResult> add_many(std::span<const ChunkAddition> adds);
  // Deletes Gaussians (by pool slot) from a resident chunk, e.g. after pruning.
  void remove_slots(ChunkId id, std::span<const uint32_t> slots);
  // The same for the entries at `positions` (strictly ascending) of the list write_slots(ids) wrote, e.g.
  // those a pruning pass selected in a step's view: only the chunks they fall in are touched, each in one
  // pass. The chunks' slot lists must be as they were when written, and no chunk listed twice. Returns
  // how many went.
  size_t remove_written_slots(std::span<const ChunkId> ids, std::span<const uint32_t> positions);
  // Records that the caller changed the chunk's Gaussians in the pool (optimiser step).
  void mark_dirty(ChunkId id);
  void mark_dirty(std::span<const ChunkId> ids);

  // Hint: chunks likely needed by the next steps, in the order of use, repeats allowed (replaces the
  // last hint).
  // Non-resident ones are read in the background; resident ones are evicted only when nothing
  // else can make room, the one needed last first.
  void prefetch(std::span<const ChunkId> ids);
  // Evicts one unpinned resident chunk now (writing it behind when dirty).
  void evict(ChunkId id);
  void evict_all_unpinned();
  // Writes every dirty chunk (they stay resident, now clean; with async_io on flush_threads
  // threads, after the write-behind queue has drained) and commits the manifest (the durability
  // barrier). After flush() the folder holds the whole map.
  void flush();
  // A checkpoint written behind the caller: the map as it is at this call (the modified resident
  // chunks and what is on disk) becomes the committed map while the caller goes on changing it.
  // Each modified chunk is copied out of the pool just before the caller could change it (pin,
  // add, remove_slots, eviction), after waiting until the writers hold less than their limit;
  // advance_checkpoint() between steps copies the rest out a little at a time, so host memory holds
  // at most ~1/32 of the budget of them. `before_commit` and
  // `after_commit` run on a writer thread around the manifest commit. Once it is committed, a
  // chunk not changed since it was copied out takes the checkpoint's file as its live file and is
  // clean again, so the next checkpoint (the final one included) and its eviction write only what
  // changed since. One still in flight is finished first. Time the caller is blocked counts as
  // checkpoint time.
  void begin_checkpoint(std::function<void()> before_commit, std::function<void()> after_commit);
  // Copies out a portion; collects a finished checkpoint (rethrowing its failure).
  void advance_checkpoint();
  bool checkpoint_in_flight() const { return checkpoint_ != nullptr; }
  void finish_checkpoint();  // copies out the rest and waits until it is committed
  // Changes the budget (e.g. raised during loop closure); lowering evicts unpinned chunks.
  // Returns false (and changes nothing) when pinned chunks alone exceed the new budget.
  bool set_budget(size_t gaussians);

  bool is_resident(ChunkId id) const { return resident_.count(id) > 0; }
  bool all_resident() const { return resident_.size() >= catalogue_.size(); }  // the whole map in the budget
  bool is_pinned(ChunkId id) const;
  bool is_dirty(ChunkId id) const;
  const std::vector<uint32_t>& slots(ChunkId id) const;  // throws when not resident
  // Appends the slots of the given resident chunks (the index list a renderer takes).
  void append_slots(std::span<const ChunkId> ids, std::vector<uint32_t>& out) const;
  // The same list written into room of its own size (slot_count), e.g. a backend's upload buffer.
  size_t slot_count(std::span<const ChunkId> ids) const;
  void write_slots(std::span<const ChunkId> ids, std::span<uint32_t> out) const;
  std::vector<ChunkId> resident_chunks() const;

  uint64_t count(ChunkId id) const;  // Gaussians in any chunk of the map (0 if unknown)
  bool contains(ChunkId id) const { return catalogue_.count(id) > 0; }
  const std::unordered_map<ChunkId, uint64_t>& catalogue() const { return catalogue_; }
  // Increases whenever a chunk enters or leaves the catalogue (lets the culler rebuild lazily).
  uint64_t catalogue_version() const { return catalogue_version_; }

  size_t budget() const { return budget_; }
  size_t resident_gaussians() const { return resident_gaussians_; }
  size_t pinned_gaussians() const { return pinned_gaussians_; }
  size_t peak_resident_gaussians() const { return peak_resident_; }
  IoStats stats() const { return store_.counters().snapshot(); }
  // The host memory of the chunks in flight. Residency maps it at construction but takes no memory
  // for it until used; a run that will fill its budget makes it resident at the start
  // (make_resident), so that host RSS does not move when the queues first fill.
  HostBlockPool& in_flight_blocks() { return host_blocks_; }
  const HostBlockPool& in_flight_blocks() const { return host_blocks_; }
  ChunkStore& store() { return store_; }
  GaussianPool& pool() { return pool_; }

 private:
  // Gives the chunk's `gone` slots (ascending) back to the pool, once they have left its slot list.
  void drop_slots(ChunkId id, std::span<const uint32_t> gone);
  struct Resident {
    std::vector<uint32_t> slots;
    int pins = 0;
    bool dirty = false;
    std::list<ChunkId>::iterator lru;  // position in lru_ (front: most recently used)
  };
  // Evicts unpinned chunks outside `keep` until `extra` more Gaussians fit; false if impossible.
  bool make_room(uint64_t extra, std::span<const ChunkId> keep, size_t* evicted);
  // Makes the chunks resident (none of them is), reading those not read ahead.
  void load_many(std::span<const ChunkId> ids);
  // Their contents, read ahead or now, checked against the map's counts; counted.
  std::vector<std::shared_ptr<const HostBlock>> take_blocks(std::span<const ChunkId> ids);
  // Evicts unpinned resident chunks; the modified ones are copied out a portion at a time and
  // written behind.
  void evict_entries(std::span<const ChunkId> ids);
  void evict_one(ChunkId id, std::shared_ptr<const HostBlock> block);  // block: its copy if modified
  void touch(Resident& r, ChunkId id);
  Resident& resident_entry(ChunkId id, const char* what);
  void check_budget_invariant() const;
  std::string over_budget_message(uint64_t pinned, size_t chunks) const;
  // The chunk's content for a checkpoint in flight that still needs it (else null): gathered
  // now and handed to the writer. Must run before anything changes the chunk's slots.
  std::shared_ptr<const HostBlock> copy_out(ChunkId id);
  // copy_out of several chunks with one gather from the pool (on a GPU one transfer, not one
  // each); the copies handed over, in the order of `ids`, of those the checkpoint still needed.
  std::vector<std::shared_ptr<const HostBlock>> copy_out_many(std::span<const ChunkId> ids);
  // The contents of the resident chunks `ids`, in their order, in blocks of the in-flight pool:
  // one gather of the pool per portion of about a quarter of the checkpoint's memory (on a GPU one
  // round trip each, not one per chunk), straight into the blocks.
  std::vector<std::shared_ptr<const HostBlock>> gather_chunks(std::span<const ChunkId> ids);
  // Chunks still to copy out, about `gaussians` of them (at least one chunk while any is left).
  std::vector<ChunkId> next_portion(size_t gaussians) const;
  size_t checkpoint_memory_limit() const;
  // Gaussians moved between the pool and host memory in one transfer (a quarter of the checkpoint's
  // memory): evictions, loads and the checkpoints' copies all go in portions of this size.
  size_t transfer_portion() const { return std::max<size_t>(checkpoint_memory_limit() / 4, 1); }
  // A committed checkpoint: chunks unchanged since their copy take its files as their live ones.
  void adopt_checkpoint();

  ChunkStore& store_;
  GaussianPool& pool_;
  ResidencyConfig config_;
  size_t budget_;
  std::unordered_map<ChunkId, uint64_t> catalogue_;
  uint64_t catalogue_version_ = 0;
  std::unordered_map<ChunkId, Resident> resident_;
  std::list<ChunkId> lru_;
  std::vector<ChunkId> hint_;                          // the latest prefetch(), in the order of use
  std::unordered_map<ChunkId, size_t> hint_rank_;      // its chunks: place in hint_
  void queue_reads_ahead();
  size_t resident_gaussians_ = 0, pinned_gaussians_ = 0, peak_resident_ = 0;
  HostBlockPool host_blocks_;   // before io_ and checkpoint_, which hold blocks of it
  std::unique_ptr<IoWorker> io_;
  std::unique_ptr<CheckpointWriter> checkpoint_;  // in flight (begin_checkpoint)
  std::unordered_set<ChunkId> checkpoint_todo_;   // modified at its moment, not yet copied out
  std::unordered_set<ChunkId> checkpoint_clean_;  // copied out and not changed since
  std::function<void()> checkpoint_before_, checkpoint_after_;
  std::chrono::steady_clock::time_point checkpoint_started_;
};

}  // namespace chungs
