#include "chungs/mapping/loop_corrector.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <optional>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/common/progress.hpp"
#include "chungs/render/sh.hpp"

namespace chungs {

nlohmann::json PoseCorrectionStats::to_json() const {
  return {{"keyframes", keyframes},
          {"gaussians_moved", gaussians_moved},
          {"chunks_touched", chunks_touched},
          {"chunks_created", chunks_created},
          {"gaussians_changed_chunk", gaussians_changed_chunk},
          {"junction_gaussians", junction_gaussians},
          {"batch", batch},
          {"apply_ms", apply_ms},
          {"refine_ms", refine_ms}};
}

void KeyframeChunkIndex::add(uint32_t keyframe, ChunkId chunk) {
  auto& v = chunks_[keyframe];
  const auto it = std::lower_bound(v.begin(), v.end(), chunk);
  if (it == v.end() || *it != chunk) v.insert(it, chunk);
}

std::vector<ChunkId> KeyframeChunkIndex::chunks_of(std::span<const uint32_t> keyframes) const {
  std::vector<ChunkId> out;
  for (uint32_t k : keyframes) {
    const auto it = chunks_.find(k);
    if (it != chunks_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void KeyframeChunkIndex::append_json(TextPieces& out) const {
  std::vector<uint32_t> keyframes;
  keyframes.reserve(chunks_.size());
  for (const auto& kv : chunks_) keyframes.push_back(kv.first);
  std::sort(keyframes.begin(), keyframes.end());
  out += '{';
  char buf[24];
  for (size_t i = 0; i < keyframes.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s\"%u\":[", i ? "," : "", unsigned(keyframes[i]));
    out += buf;
    const std::vector<ChunkId>& list = chunks_.at(keyframes[i]);
    for (size_t c = 0; c < list.size(); ++c) {
      std::snprintf(buf, sizeof buf, "%s\"%llx\"", c ? "," : "", (unsigned long long)list[c]);
      out += buf;
    }
    out += ']';
  }
  out += '}';
}

size_t KeyframeChunkIndex::entries() const {
  size_t n = 0;
  for (const auto& kv : chunks_) n += kv.second.size();
  return n;
}

KeyframeChunkIndex KeyframeChunkIndex::from_json(const nlohmann::json& j) {
  if (!j.is_object()) fail("keyframe chunk index: expected an object, got ", j.type_name());
  KeyframeChunkIndex idx;
  for (const auto& [key, list] : j.items()) {
    size_t used = 0;
    unsigned long k = 0;
    try {
      k = std::stoul(key, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != key.size() || k > UINT32_MAX) fail("keyframe chunk index: '", key, "' is not a keyframe id");
    if (!list.is_array()) fail("keyframe chunk index: keyframe ", key, ": expected a list of chunk ids");
    for (const auto& e : list) {
      const std::string s = e.is_string() ? e.get<std::string>() : std::string();
      size_t n = 0;
      unsigned long long c = 0;
      try {
        c = std::stoull(s, &n, 16);
      } catch (const std::exception&) {
        n = 0;
      }
      if (s.empty() || n != s.size())
        fail("keyframe chunk index: keyframe ", key, ": bad chunk id ", e.dump());
      idx.add(uint32_t(k), ChunkId(c));
    }
  }
  return idx;
}

void transform_gaussian(const SE3& delta, float* mean, float* rotation) {
  const Eigen::Vector3d p = delta * Eigen::Vector3d(mean[0], mean[1], mean[2]);
  for (int a = 0; a < 3; ++a) mean[a] = float(p[a]);
  // Left-multiplying by a unit quaternion keeps the stored (unnormalised) norm.
  const Eigen::Quaterniond q(rotation[0], rotation[1], rotation[2], rotation[3]);
  const Eigen::Quaterniond r = delta.q * q;
  rotation[0] = float(r.w());
  rotation[1] = float(r.x());
  rotation[2] = float(r.y());
  rotation[3] = float(r.z());
}

namespace {

// Directions spread evenly over the sphere (a Fibonacci lattice): more than the 7 functions of the
// largest band, so the least-squares fit below is exact and well conditioned.
constexpr int kShSamples = 32;
const std::array<Eigen::Vector3d, kShSamples>& sample_directions() {
  static const std::array<Eigen::Vector3d, kShSamples> dirs = [] {
    std::array<Eigen::Vector3d, kShSamples> d;
    const double golden = M_PI * (3 - std::sqrt(5.0));
    for (int i = 0; i < kShSamples; ++i) {
      const double z = 1 - (2 * i + 1) / double(kShSamples), r = std::sqrt(1 - z * z);
      d[i] = Eigen::Vector3d(r * std::cos(golden * i), r * std::sin(golden * i), z);
    }
    return d;
  }();
  return dirs;
}

template <int N>
Eigen::Matrix<double, N, N> band_rotation(const Eigen::Matrix3d& R, int first) {
  // A holds the band's basis at the sample directions, C at the directions rotated back; a band is
  // closed under rotation, so C = A M has an exact solution.
  Eigen::Matrix<double, kShSamples, N> A, C;
  double b[kShCoeffs];
  for (int j = 0; j < kShSamples; ++j) {
    const Eigen::Vector3d& d = sample_directions()[j];
    sh::basis<double>(kMaxShDegree, d.x(), d.y(), d.z(), b);
    for (int k = 0; k < N; ++k) A(j, k) = b[first + k];
    const Eigen::Vector3d e = R.transpose() * d;
    sh::basis<double>(kMaxShDegree, e.x(), e.y(), e.z(), b);
    for (int k = 0; k < N; ++k) C(j, k) = b[first + k];
  }
  return A.colPivHouseholderQr().solve(C);
}

template <int N>
void rotate_band(const Eigen::Matrix<double, N, N>& M, int first, float* sh) {
  for (int c = 0; c < 3; ++c) {
    Eigen::Matrix<double, N, 1> f;
    for (int k = 0; k < N; ++k) f[k] = sh[3 * (first + k) + c];
    const Eigen::Matrix<double, N, 1> g = M * f;
    for (int k = 0; k < N; ++k) sh[3 * (first + k) + c] = float(g[k]);
  }
}

}  // namespace

ShRotation sh_rotation(const Eigen::Matrix3d& R) {
  return {band_rotation<3>(R, 1), band_rotation<5>(R, 4), band_rotation<7>(R, 9)};
}

void rotate_sh(const ShRotation& m, int degree, float* sh) {
  if (degree >= 1) rotate_band<3>(m.band1, 1, sh);
  if (degree >= 2) rotate_band<5>(m.band2, 4, sh);
  if (degree >= 3) rotate_band<7>(m.band3, 9, sh);
}

namespace {

class Corrector {
 public:
  Corrector(Residency& r, double s, const PoseCorrection& c, KeyframeChunkIndex& idx)
      : res_(r), size_(s), corr_(c), index_(idx) {}

  PoseCorrectionStats run(std::span<const ChunkId> candidates) {
    const auto t0 = std::chrono::steady_clock::now();
    for (ChunkId c : candidates)
      if (res_.count(c) > 0) todo_.push_back(c);
    std::sort(todo_.begin(), todo_.end());
    todo_.erase(std::unique(todo_.begin(), todo_.end()), todo_.end());
    uint64_t total = 0;
    for (ChunkId c : todo_) total += res_.count(c);
    const size_t old_budget = res_.budget();
    stats_.batch = corr_.allow_batch && res_.pinned_gaussians() + total <= res_.pool().capacity();
    if (stats_.batch) {
      if (res_.pinned_gaussians() + total > old_budget && !res_.set_budget(res_.pool().capacity()))
        stats_.batch = false;
      if (stats_.batch) {
        const PinResult pr = res_.pin(todo_);
        if (!pr.ok) {
          stats_.batch = false;
          res_.set_budget(old_budget);
        }
      }
    }
    // Only a large event gets a progress bar: bundle-adjustment updates come every few keyframes.
    std::optional<Progress> progress;
    if (todo_.size() >= 200) progress.emplace("loop correction", (long long)todo_.size());
    try {
      for (size_t i = 0; i < todo_.size(); ++i) {
        const ChunkId c = todo_[i];
        if (!stats_.batch) {
          if (i + 1 < todo_.size()) res_.prefetch(std::span<const ChunkId>(&todo_[i + 1], 1));
          const PinResult pr = res_.pin(std::span<const ChunkId>(&c, 1));
          if (!pr.ok) fail("loop correction: ", pr.message);
        }
        visit(c, i);
        if (!stats_.batch) res_.unpin(std::span<const ChunkId>(&c, 1));
        if (progress) progress->step();
      }
    } catch (...) {
      if (stats_.batch) {
        res_.unpin(todo_);
        res_.set_budget(old_budget);
      }
      throw;
    }
    if (progress) progress->finish();
    if (stats_.batch) res_.unpin(todo_);
    // Every chunk has been visited: the Gaussians that waited for theirs can go in now.
    for (auto& [dest, block] : waiting_) {
      const PinResult pr = add_to(dest, block);
      if (!pr.ok)
        fail("loop correction: ", block.size(), " Gaussians moved into ", chunk_name(dest),
             " do not fit beside its ", res_.count(dest), " under the budget of ", res_.budget(), ": ",
             pr.message);
    }
    if (stats_.batch && res_.budget() != old_budget) res_.set_budget(old_budget);
    stats_.chunks_touched = touched_.size();
    stats_.apply_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return stats_;
  }

 private:
  PinResult add_to(ChunkId dest, const GaussianBlock& block) {
    const bool known = res_.contains(dest);
    const PinResult pr = res_.add(dest, block);
    if (pr.ok) {
      if (!known) ++stats_.chunks_created;
      touched_.insert(dest);
      for (uint32_t k : block.created_by_keyframe) index_.add(k, dest);
    }
    return pr;
  }

  void visit(ChunkId c, size_t position) {
    const std::vector<uint32_t> slots = res_.slots(c);  // a copy: removal below changes the list
    GaussianBlock block;
    res_.pool().gather(slots, block);
    GaussianBlock stay;
    std::vector<uint32_t> stay_slots, leave_slots;
    std::unordered_map<ChunkId, GaussianBlock> leaving;
    for (size_t i = 0; i < block.size(); ++i) {
      const uint32_t kf = block.created_by_keyframe[i];
      const auto d = corr_.delta.find(kf);
      const bool junction = corr_.junction.count(kf) > 0;
      GaussianParams& p = block.params;
      if (d != corr_.delta.end()) {
        transform_gaussian(d->second, &p.mean[3 * i], &p.rotation[4 * i]);
        if (block.sh_degree > 0)
          rotate_sh(sh_of(kf, d->second), block.sh_degree, &p.sh[size_t(kShFloats) * i]);
        ++stats_.gaussians_moved;
      }
      const bool reshaped = corr_.reshape && corr_.reshape(block, i);
      stats_.gaussians_moved += reshaped;
      if (junction) {
        p.opacity[i] = corr_.reset_opacity_logit;
        for (GaussianParams* m : {&block.adam_m, &block.adam_v}) {
          std::fill_n(&m->mean[3 * i], 3, 0.f);
          std::fill_n(&m->log_scale[3 * i], 3, 0.f);
          std::fill_n(&m->rotation[4 * i], 4, 0.f);
          m->opacity[i] = 0.f;
          std::fill_n(&m->sh[size_t(kShFloats) * i], kShFloats, 0.f);
        }
        block.adam_steps[i] = 0;
        block.lr_position_factor[i] = 1.f;
        ++stats_.junction_gaussians;
      }
      const Eigen::Vector3d m(p.mean[3 * i], p.mean[3 * i + 1], p.mean[3 * i + 2]);
      // A diverged Gaussian (non-finite mean) has no chunk of its own: it stays where it is.
      // Every Gaussian of a visited chunk is re-filed, also one that the optimiser carried out
      // of its chunk earlier: afterwards each lies in the chunk of its position.
      const ChunkId dest = chunk_of(m, c);
      if (dest == c) {
        if (d == corr_.delta.end() && !junction && !reshaped) continue;
        stay.append(block, i);
        stay_slots.push_back(slots[i]);
      } else {
        leaving[dest].append(block, i);
        leave_slots.push_back(slots[i]);
      }
    }
    touched_.insert(c);
    if (stay_slots.empty() && leave_slots.empty()) return;
    if (!stay_slots.empty()) res_.pool().scatter(stay, stay_slots);
    if (!leave_slots.empty()) res_.remove_slots(c, leave_slots);
    res_.mark_dirty(c);
    for (auto& [dest, moved] : leaving) {
      stats_.gaussians_changed_chunk += moved.size();
      // A destination still to be visited must not see them (they would move twice).
      const bool later = visited_after(dest, position);
      if (!later && fits(dest, moved.size()) && add_to(dest, moved).ok) continue;
      GaussianBlock& w = waiting_[dest];
      for (size_t i = 0; i < moved.size(); ++i) w.append(moved, i);
    }
  }

  // Whether `n` more Gaussians fit into `dest` beside the pinned chunks now (asked first, so that a
  // full residency defers them to the end instead of refusing with a warning).
  bool fits(ChunkId dest, size_t n) const {
    const uint64_t need = res_.pinned_gaussians() + (res_.is_pinned(dest) ? 0 : res_.count(dest)) + n;
    return need <= res_.budget();
  }

  const ShRotation& sh_of(uint32_t kf, const SE3& delta) {
    auto it = sh_.find(kf);
    if (it == sh_.end()) it = sh_.emplace(kf, sh_rotation(delta.rotation())).first;
    return it->second;
  }

  // The chunk of a position at the level of `current`, its chunk now; `current` for a position that
  // has none (not finite, or beyond the range of chunk coordinates).
  ChunkId chunk_of(const Eigen::Vector3d& p, ChunkId current) const {
    if (!p.allFinite()) return current;
    const Eigen::Vector3d q = p / size_;
    if (q.cwiseAbs().maxCoeff() >= double(kChunkCoordMax)) return current;
    const ChunkId id = chunk_id_of(p, size_);
    return is_far_level(current) ? far_level_of(id) : id;
  }

  // Whether chunk `dest` is on the to-do list after position `current` (still to be visited).
  bool visited_after(ChunkId dest, size_t current) const {
    const auto it = std::lower_bound(todo_.begin(), todo_.end(), dest);
    return it != todo_.end() && *it == dest && size_t(it - todo_.begin()) > current;
  }

  Residency& res_;
  double size_;
  const PoseCorrection& corr_;
  KeyframeChunkIndex& index_;
  std::vector<ChunkId> todo_;  // sorted: visiting order
  std::unordered_set<ChunkId> touched_;
  std::map<ChunkId, GaussianBlock> waiting_;
  std::unordered_map<uint32_t, ShRotation> sh_;  // per moved keyframe, computed on first use
  PoseCorrectionStats stats_;
};

}  // namespace

PoseCorrectionStats apply_pose_correction(Residency& residency, double chunk_size,
                                          const PoseCorrection& correction,
                                          std::span<const ChunkId> candidates, KeyframeChunkIndex& index) {
  if (!(chunk_size > 0)) fail("loop correction: chunk size must be positive, got ", chunk_size);
  for (const auto& [k, d] : correction.delta)
    if (!d.t.allFinite() || !d.q.coeffs().allFinite())
      fail("loop correction: the pose change of keyframe ", k, " is not finite");
  Corrector c(residency, chunk_size, correction, index);
  return c.run(candidates);
}

}  // namespace chungs
