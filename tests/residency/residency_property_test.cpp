// Long random sequences of insert / modify / prune / pin / unpin / evict / prefetch / checkpoint / reopen
// against a plain in-memory model of the map. Every Gaussian carries a unique tag (its
// created_at_step) so that loss, duplication, or any changed bit is caught wherever it lives:
// in the pool, in the write-behind queue, or on disk.
#include <gtest/gtest.h>

#include <map>
#include <cstring>
#include <random>
#include <set>

#include "chungs/common/log.hpp"

#include "chungs/residency/residency.hpp"
#include "store/random_block.hpp"
#include "test_support.hpp"

using namespace chungs;

namespace {

using Model = std::map<ChunkId, std::map<uint32_t, GaussianBlock>>;  // chunk -> tag -> one Gaussian

// Gaussian i of a equals Gaussian j of b in every array, bit for bit.
bool same_gaussian(const GaussianBlock& a, size_t i, const GaussianBlock& b, size_t j) {
  auto eq = [](const auto& x, size_t xi, const auto& y, size_t yi, size_t w) {
    return std::memcmp(&x[xi * w], &y[yi * w], w * sizeof x[0]) == 0;
  };
  auto eqp = [&](const GaussianParams& x, const GaussianParams& y) {
    return eq(x.mean, i, y.mean, j, 3) && eq(x.log_scale, i, y.log_scale, j, 3) &&
           eq(x.rotation, i, y.rotation, j, 4) && eq(x.opacity, i, y.opacity, j, 1) &&
           eq(x.sh, i, y.sh, j, kShFloats);
  };
  return eqp(a.params, b.params) && eqp(a.adam_m, b.adam_m) && eqp(a.adam_v, b.adam_v) &&
         eq(a.adam_steps, i, b.adam_steps, j, 1) && eq(a.created_by_keyframe, i, b.created_by_keyframe, j, 1) &&
         eq(a.created_at_step, i, b.created_at_step, j, 1) &&
         eq(a.lr_position_factor, i, b.lr_position_factor, j, 1);
}

GaussianBlock one(const GaussianBlock& b, size_t i) {
  GaussianBlock g;
  g.sh_degree = b.sh_degree;
  g.append(b, i);
  return g;
}

// Every Gaussian of `b` is in the model's chunk, once, bit-exact, and nothing is missing.
void expect_matches(const Model& model, ChunkId id, const GaussianBlock& b, const std::string& where) {
  auto it = model.find(id);
  const size_t want = it == model.end() ? 0 : it->second.size();
  ASSERT_EQ(b.size(), want) << where << ": " << chunk_name(id) << " Gaussian count";
  std::set<uint32_t> seen;
  for (size_t i = 0; i < b.size(); ++i) {
    const uint32_t tag = b.created_at_step[i];
    ASSERT_TRUE(seen.insert(tag).second) << where << ": duplicated Gaussian " << tag;
    auto g = it->second.find(tag);
    ASSERT_NE(g, it->second.end()) << where << ": unknown Gaussian " << tag << " in " << chunk_name(id);
    ASSERT_TRUE(same_gaussian(b, i, g->second, 0)) << where << ": Gaussian " << tag << " changed";
  }
}

class World {
 public:
  World(bool async, uint32_t seed) : async_(async), rng_(seed) { open(); }

  void open() {
    ChunkStoreConfig sc;
    sc.half_moments = sc.half_sh_rest = false;  // these tests compare exact round trips
    sc.durable = false;
    sc.compress = rng_() % 2 == 0;
    store_ = std::make_unique<ChunkStore>(dir_.path(), sc);
    pool_ = std::make_unique<CpuGaussianPool>(kCapacity);
    ResidencyConfig rc;
    rc.budget_gaussians = kBudget;
    rc.async_io = async_;
    rc.prefetch_max_gaussians = 1500;
    rc.write_behind_max_gaussians = 1500;
    res_ = std::make_unique<Residency>(*store_, *pool_, rc);
    pinned_.clear();
  }
  void reopen() {
    add_stats(res_->stats());
    res_.reset();  // flushes
    store_.reset();
    open();
  }

  ChunkId random_chunk() { return chunk_id({int(rng_() % 5), int(rng_() % 4), int(rng_() % 2)}); }
  std::vector<ChunkId> resident() const { return res_->resident_chunks(); }

  void insert() {
    const ChunkId id = random_chunk();
    if (res_->count(id) > 600) return;  // keep chunks well below the budget so pins mostly fit
    GaussianBlock b = test::random_block(1 + rng_() % 250, rng_());
    for (auto& t : b.created_at_step) t = next_tag_++;
    const uint64_t floor = res_->pinned_gaussians() + (res_->is_pinned(id) ? 0 : res_->count(id)) + b.size();
    const PinResult p = res_->add(id, b);
    ASSERT_EQ(p.ok, floor <= kBudget) << p.message;
    if (p.ok)
      for (size_t i = 0; i < b.size(); ++i) model_[id][b.created_at_step[i]] = one(b, i);
  }

  void modify() {
    auto ids = resident();
    if (ids.empty()) return;
    const ChunkId id = ids[rng_() % ids.size()];
    // As an optimiser step does: pinned while it changes (a checkpoint in flight copies it first).
    const ChunkId one_id[] = {id};
    if (!res_->pin(one_id).ok) return;
    GaussianBlock& s = pool_->storage();
    std::vector<uint32_t> changed;
    for (uint32_t slot : res_->slots(id)) {
      if (rng_() % 3) continue;
      s.params.mean[3 * slot + rng_() % 3] += 0.25f;
      s.adam_v.sh[size_t(slot) * kShFloats + rng_() % kShFloats] *= 1.5f;
      s.adam_steps[slot] += 1;
      s.lr_position_factor[slot] *= 0.998f;
      changed.push_back(slot);
    }
    GaussianBlock g;
    pool_->gather(changed, g);
    for (size_t i = 0; i < g.size(); ++i) model_[id][g.created_at_step[i]] = one(g, i);
    res_->mark_dirty(id);
    res_->unpin(one_id);
  }
  // Checkpoints written behind: after each, chunks unchanged since their copy count as written.
  void checkpoint() {
    if (!res_->checkpoint_in_flight()) res_->begin_checkpoint([] {}, [] {});
  }

  void prune() {
    auto ids = resident();
    if (ids.empty()) return;
    const ChunkId id = ids[rng_() % ids.size()];
    std::vector<uint32_t> gone;
    for (uint32_t slot : res_->slots(id))
      if (rng_() % 4 == 0) gone.push_back(slot);
    for (uint32_t slot : gone) model_[id].erase(pool_->storage().created_at_step[slot]);
    if (model_[id].empty()) model_.erase(id);
    res_->remove_slots(id, gone);
  }

  void pin() {
    std::vector<ChunkId> ids;
    for (int n = 1 + int(rng_() % 5); n > 0; --n) ids.push_back(random_chunk());
    uint64_t need = res_->pinned_gaussians();
    std::set<ChunkId> distinct(ids.begin(), ids.end());
    for (ChunkId id : distinct)
      if (!res_->is_pinned(id)) need += res_->count(id);
    const PinResult p = res_->pin(ids);
    ASSERT_EQ(p.ok, need <= kBudget) << p.message;
    if (!p.ok) {
      ASSERT_EQ(p.over_budget, need - kBudget);
      return;
    }
    std::vector<ChunkId> known;
    for (ChunkId id : ids)
      if (res_->contains(id)) known.push_back(id);
    std::sort(known.begin(), known.end());
    known.erase(std::unique(known.begin(), known.end()), known.end());
    for (ChunkId id : known) {
      GaussianBlock b;
      pool_->gather(res_->slots(id), b);
      expect_matches(model_, id, b, "after pin");
    }
    pinned_.push_back(known);
  }

  void unpin() {
    if (pinned_.empty()) return;
    const size_t k = rng_() % pinned_.size();
    res_->unpin(pinned_[k]);
    pinned_.erase(pinned_.begin() + std::ptrdiff_t(k));
  }

  void evict() {
    for (ChunkId id : resident())
      if (!res_->is_pinned(id) && rng_() % 2) res_->evict(id);
  }

  void prefetch() {
    std::vector<ChunkId> ids;
    for (int n = int(rng_() % 6); n > 0; --n) ids.push_back(random_chunk());
    res_->prefetch(ids);
  }

  // The whole map, wherever each chunk lives, equals the model; the budget holds.
  void check_all(const std::string& where) {
    ASSERT_LE(res_->resident_gaussians(), kBudget) << where;
    ASSERT_LE(res_->peak_resident_gaussians(), kBudget) << where;
    ASSERT_EQ(pool_->used(), res_->resident_gaussians()) << where << ": leaked pool slots";
    res_->flush();
    for (const auto& [id, gs] : model_) ASSERT_EQ(res_->count(id), gs.size()) << where;
    for (const auto& [id, n] : res_->catalogue()) {
      if (res_->is_resident(id)) {
        GaussianBlock b;
        pool_->gather(res_->slots(id), b);
        expect_matches(model_, id, b, where + " (resident)");
      } else {
        expect_matches(model_, id, store_->load(id), where + " (on disk)");
      }
    }
    uint64_t total = 0;
    for (const auto& [id, gs] : model_) total += gs.size();
    uint64_t listed = 0;
    for (const auto& [id, n] : res_->catalogue()) listed += n;
    ASSERT_EQ(listed, total) << where;
  }

  void run(int steps) {
    for (int step = 0; step < steps; ++step) {
      const std::string where = "step " + std::to_string(step);
      const int op = int(rng_() % 100);
      if (op < 22) insert();
      else if (op < 37) modify();
      else if (op < 45) prune();
      else if (op < 63) pin();
      else if (op < 80) unpin();
      else if (op < 86) evict();
      else if (op < 92) prefetch();
      else if (op < 94) checkpoint();
      else if (op < 97) res_->advance_checkpoint();
      else if (op < 98) res_->set_budget(kBudget);
      else reopen();
      if (::testing::Test::HasFatalFailure()) return;
      ASSERT_LE(res_->resident_gaussians(), kBudget) << where;
      ASSERT_EQ(pool_->used(), res_->resident_gaussians()) << where;
      if (step % 250 == 249) {
        check_all(where);
        if (::testing::Test::HasFatalFailure()) return;
      }
    }
    res_->unpin_all();
    pinned_.clear();
    reopen();
    check_all("after the final reopen");
  }

  // I/O over the whole run (all sessions).
  const IoStats& stats() const { return total_; }
  void add_stats(const IoStats& s) {
    total_.loads += s.loads, total_.saves += s.saves, total_.removes += s.removes;
    total_.bytes_read += s.bytes_read, total_.bytes_written += s.bytes_written;
    total_.load_ms += s.load_ms, total_.save_ms += s.save_ms, total_.wait_ms += s.wait_ms;
    total_.pool_loads += s.pool_loads, total_.prefetch_hits += s.prefetch_hits;
    total_.write_behind_hits += s.write_behind_hits, total_.sync_loads += s.sync_loads, total_.waits += s.waits;
    total_.evictions_clean += s.evictions_clean, total_.evictions_dirty += s.evictions_dirty;
    total_.checkpoints += s.checkpoints, total_.checkpoints_behind += s.checkpoints_behind;
  }

 private:
  static constexpr size_t kBudget = 3000, kCapacity = 3500;
  bool async_;
  std::mt19937 rng_;
  test::TempDir dir_;
  std::unique_ptr<ChunkStore> store_;
  std::unique_ptr<CpuGaussianPool> pool_;
  std::unique_ptr<Residency> res_;
  Model model_;
  std::vector<std::vector<ChunkId>> pinned_;
  uint32_t next_tag_ = 1;
  IoStats total_;
};

// Over-budget pins are expected here by the hundred; their warnings would bury the output.
struct QuietLog {
  log::Level saved = log::level();
  QuietLog() { log::set_level(log::Level::Error); }
  ~QuietLog() { log::set_level(saved); }
};

}  // namespace

TEST(Residency, NeverExceedsBudgetNorLosesDuplicatesOrChangesAGaussian) {
  QuietLog quiet;
  for (uint32_t seed : {1u, 2u}) {
    World w(false, seed);
    w.run(2500);
    if (HasFatalFailure()) return;
  }
}

TEST(Residency, NeverExceedsBudgetNorLosesAGaussianWithBackgroundIo) {
  QuietLog quiet;
  for (uint32_t seed : {3u, 4u}) {
    World w(true, seed);
    w.run(2500);
    if (HasFatalFailure()) return;
    std::printf("[ async    ] seed %u: %s\n", seed, w.stats().summary().c_str());
    EXPECT_GT(w.stats().checkpoints_behind, 10u);
  }
}
