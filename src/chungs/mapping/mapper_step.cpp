// Mapper's step loop: the picks drawn ahead and their chunks read in the background, and one
// optimisation step on a keyframe's view: whole, its core, the resident part of it (partial views), or
// without the pixels that views gone from the window showed better.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "chungs/common/log.hpp"
#include "chungs/common/stopwatch.hpp"
#include "chungs/mapping/mapper.hpp"

namespace chungs {

std::optional<uint32_t> Mapper::revisit_pick() {
  const KeyframeSelectorConfig& sc = config_.selector;
  if (!(sc.revisit_share > 0) || keyframes_.empty()) return std::nullopt;
  revisit_credit_ += sc.revisit_share;  // at every pick, a burst's own included
  if (revisit_left_ == 0) {
    if (revisit_credit_ < double(sc.revisit_burst)) return std::nullopt;
    // A burst: one keyframe drawn among those far enough behind, and its neighbours.
    const Eigen::Vector3d at = keyframes_.back().pose.t;
    const double far = sc.cell_size / 2;
    std::vector<const KeyframeRecord*> behind;
    for (const KeyframeRecord& k : keyframes_) {
      const double d = (k.pose.t - at).norm();
      if (d > sc.revisit_min_distance && d <= far) behind.push_back(&k);
    }
    if (behind.empty()) {
      revisit_credit_ = double(sc.revisit_burst);  // a drive still too short: kept, not piled up
      return std::nullopt;
    }
    revisit_credit_ -= double(sc.revisit_burst);
    const KeyframeRecord* anchor = behind[std::uniform_int_distribution<size_t>(0, behind.size() - 1)(rng_)];
    revisit_group_.clear();
    for (const KeyframeRecord* k : behind)
      if ((k->pose.t - anchor->pose.t).norm() <= sc.revisit_group_m) revisit_group_.push_back(k->id);
    revisit_left_ = sc.revisit_burst;
    ++window_stats_.revisit_bursts;
  }
  --revisit_left_;
  return revisit_group_[std::uniform_int_distribution<size_t>(0, revisit_group_.size() - 1)(rng_)];
}

void Mapper::draw_pick_ahead() {
  if (const std::optional<uint32_t> r = revisit_pick()) {
    if (const KeyframeRecord* k = find_keyframe(*r)) {
      // Its core is loaded as a window keyframe's would be; the burst's next picks need the same chunks.
      PickAhead p{k->id, visible_chunks(k->camera, k->pose), true};
      if (loads_cores()) {
        const std::vector<ChunkId>& core = core_chunks_of(*k);
        std::erase_if(p.chunks, [&](ChunkId c) { return !std::binary_search(core.begin(), core.end(), c); });
      }
      keyframe_store_->prefetch(k->id);
      picks_ahead_.push_back(std::move(p));
      return;
    }
  }
  const PickScope scope = config_.selector.partial_views ? PickScope::cell : PickScope::window;
  PickAhead p{selector_.pick(rng_, scope), {}};
  // A pick outside the window loads no chunk: its step uses what is resident. Its images are read
  // ahead all the same (they are scored, and its coverage is built from its depth): on a 2 km street
  // under a 300 k budget, 432 keyframe reads had waited, 0.85 s of the optimiser's time.
  if (const KeyframeRecord* k = find_keyframe(p.keyframe)) {
    if (selector_.in_window(k->id)) {
      p.chunks = visible_chunks(k->camera, k->pose);
      // Only the core is loaded; a view whose coverage is not built yet predicts all it sees, since
      // building it here would wait for the images that the prefetch below reads.
      const std::vector<ChunkId>* core = loads_cores() ? known_core(*k) : nullptr;
      if (core)
        std::erase_if(p.chunks, [&](ChunkId c) { return !std::binary_search(core->begin(), core->end(), c); });
    }
    keyframe_store_->prefetch(k->id);
  }
  picks_ahead_.push_back(std::move(p));
}

void Mapper::give_back_picks_ahead() {
  for (const PickAhead& p : picks_ahead_)
    if (!p.revisit) selector_.give_back(p.keyframe);
  picks_ahead_.clear();
}

uint32_t Mapper::window_pick_ahead() {
  // A window keyframe drawn ahead has its chunks read already (or in flight); one drawn now waits
  // for all of them: on a 2 km street under a 100 k budget 43 % of the steps came here, and two
  // thirds of the chunk loads waited on the disk.
  const auto it = std::find_if(picks_ahead_.begin(), picks_ahead_.end(),
                               [&](const PickAhead& p) { return selector_.in_window(p.keyframe); });
  if (it == picks_ahead_.end()) return selector_.pick(rng_, PickScope::window);
  const uint32_t id = it->keyframe;
  picks_ahead_.erase(it);
  return id;
}

StepStats Mapper::step() {
  if (keyframes_.empty()) fail("mapper: an optimisation step needs at least one keyframe");
  const auto t0 = std::chrono::steady_clock::now();
  residency_->advance_checkpoint();
  // The keyframes of the next steps are drawn now and their chunks read in the background while
  // the steps before them run, so that their pins find them in host memory instead of waiting on
  // the disk: a view's ~20 chunk loads under a 100 k budget take longer than one GPU step.
  const size_t ahead = size_t(config_.mapper.read_ahead_steps);
  while (picks_ahead_.size() <= ahead) draw_pick_ahead();
  const uint32_t keyframe = picks_ahead_.front().keyframe;
  const bool revisit = picks_ahead_.front().revisit;
  if (!residency_->all_resident()) {  // else nothing to read, and nothing is evicted
    std::vector<ChunkId> wanted;  // in the order of use, this step's first (what is staged for it stays)
    for (const PickAhead& p : picks_ahead_) wanted.insert(wanted.end(), p.chunks.begin(), p.chunks.end());
    residency_->prefetch(wanted);
  }
  picks_ahead_.pop_front();
  step_times_.pick_ms += ms_since(t0);
  return step_keyframe(keyframe, false, revisit);
}

const ViewCoverage& Mapper::coverage_of(const KeyframeRecord& kf) {
  auto it = coverage_.find(kf.id);
  if (it == coverage_.end()) {
    const std::shared_ptr<const KeyframeImages> images = keyframe_store_->get(kf.id);
    ViewCoverage built;  // no depth map: nothing known of where its pixels look
    if (!images->depth.empty())
      built = ViewCoverage(images->depth, kf.camera, kf.pose, grid(), config_.sampler.fill_depth);
    it = coverage_.emplace(kf.id, std::move(built)).first;
  }
  return it->second;
}


Mapper::StepTimes Mapper::StepTimes::operator-(const StepTimes& b) const {
  StepTimes d = *this;
  d.steps -= b.steps, d.keyframe_loads -= b.keyframe_loads;
  d.total_ms -= b.total_ms, d.chunks_ms -= b.chunks_ms, d.keyframe_load_ms -= b.keyframe_load_ms;
  d.backend_ms -= b.backend_ms, d.pick_ms -= b.pick_ms, d.cull_ms -= b.cull_ms, d.pin_ms -= b.pin_ms;
  d.bookkeeping_ms -= b.bookkeeping_ms, d.slots_ms -= b.slots_ms, d.prune_ms -= b.prune_ms;
  return d;
}

StepStats Mapper::step_keyframe(uint32_t keyframe, bool whole_view, bool revisit) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  StepStats st;
  st.keyframe = keyframe;
  const KeyframeRecord* found = find_keyframe(keyframe);
  if (!found) fail("mapper: no keyframe ", keyframe, " to train on");
  const KeyframeRecord& kf = *found;
  std::vector<ChunkId> left_out;
  std::vector<ChunkId> chunks = visible_chunks(kf.camera, kf.pose, &left_out);
  step_times_.cull_ms += ms_since(t0);
  // Checked here, not only in chunks_shown_better: without masks the view's coverage need not be built.
  const bool masks = config_.selector.best_view_share > 0 && selector_.restricted() && !refining_;
  const std::vector<ChunkId> shown_better =
      masks ? chunks_shown_better(kf.id, coverage_of(kf)) : std::vector<ChunkId>();
  const auto trained = [&](ChunkId c) { return !std::binary_search(shown_better.begin(), shown_better.end(), c); };
  // Outside the window: the resident part of the view, scored only where it explains the image.
  std::optional<Image8> pixel_mask;
  bool part_of_view = false;  // a partial or trimmed view
  std::vector<ChunkId> beyond_core_drawn;
  if (revisit) ++window_stats_.revisit_steps;
  st.revisit = revisit;
  if (!whole_view && !revisit && !selector_.in_window(kf.id)) {
    std::erase_if(chunks, [&](ChunkId c) { return !residency_->is_resident(c); });
    std::sort(chunks.begin(), chunks.end());
    const auto rendered = [&](ChunkId c) { return std::binary_search(chunks.begin(), chunks.end(), c); };
    const ViewCoverage& coverage = coverage_of(kf);
    if (coverage.coverage(rendered) < config_.selector.min_partial_coverage) {
      ++window_stats_.partial_too_small;
      selector_.give_back(kf.id);
      return step_keyframe(window_pick_ahead());
    }
    pixel_mask = coverage.mask([&](ChunkId c) { return rendered(c) && trained(c); });
    ++window_stats_.partial_steps;
    part_of_view = true;
  } else {
    // Beyond its core, a view draws what is resident and leaves out the pixels of the rest.
    size_t beyond_core = 0;
    if (!whole_view && loads_cores()) {
      const std::vector<ChunkId>& core = core_chunks_of(kf);
      const size_t before = left_out.size();
      std::erase_if(chunks, [&](ChunkId c) {
        if (std::binary_search(core.begin(), core.end(), c)) return false;
        (residency_->is_resident(c) ? beyond_core_drawn : left_out).push_back(c);
        return true;
      });
      beyond_core = left_out.size() - before;
    }
    if (!left_out.empty()) {
      // A view that needs more than the budget is drawn without its farthest chunks. Unmasked, their
      // pixels would teach the sky and the near Gaussians' edges to paint the far street.
      const bool over_budget = left_out.size() > beyond_core;
      std::sort(left_out.begin(), left_out.end());
      pixel_mask = coverage_of(kf).mask(
          [&](ChunkId c) { return !std::binary_search(left_out.begin(), left_out.end(), c) && trained(c); }, true);
      if (over_budget) {
        ++window_stats_.trimmed_steps;
        part_of_view = true;
      } else {
        ++window_stats_.beyond_core_steps;
      }
    } else if (!shown_better.empty()) {
      pixel_mask = coverage_of(kf).mask(trained, true);
    }
  }
  // A keyframe without depth (one camera's, before its neighbours gave it some) has no coverage, so no
  // mask can tell its left-out chunks' pixels: all are scored (its 0x0 mask failed the step's loss).
  if (pixel_mask && pixel_mask->empty()) pixel_mask.reset();
  if (!shown_better.empty()) ++window_stats_.best_view_steps;
  const auto tp = clock::now();
  auto t2 = tp;
  const PinResult pr = residency_->pin(chunks, !part_of_view);
  if (!pr.ok) fail("mapper: cannot make the chunks of keyframe ", kf.id, " resident: ", pr.message);
  if (!beyond_core_drawn.empty()) {
    // Drawn because they are resident, but not kept so for this view's sake: the window's cores are.
    const PinResult more = residency_->pin(beyond_core_drawn, false);
    if (!more.ok) {
      residency_->unpin(chunks);
      fail("mapper: cannot pin the resident chunks of keyframe ", kf.id, ": ", more.message);
    }
    chunks.insert(chunks.end(), beyond_core_drawn.begin(), beyond_core_drawn.end());
  }
  step_times_.pin_ms += ms_since(tp);
  try {
    // Written where the backend uploads it from (the GPU's pinned staging): no copy of the list.
    const std::span<uint32_t> slots = backend_->slot_buffer(residency_->slot_count(chunks));
    const auto ts = clock::now();
    residency_->write_slots(chunks, slots);
    step_times_.slots_ms += ms_since(ts);
    step_times_.chunks_ms += ms_since(t0);
    const auto t1 = clock::now();
    // Pruning runs on the step that completes `every` iterations, as before the backend split.
    const bool prune = config_.prune.every > 0 && (iterations_ + 1) % uint64_t(config_.prune.every) == 0;
    // Keyframe ids are never reused within a map, so the id and the depth's version name the images.
    const StepTargets targets{(uint64_t(kf.depth_version) << 32) + uint64_t(kf.id) + 1, config_.loss.lambda_depth > 0,
                              [&] {
                                const auto tl = clock::now();
                                auto images = keyframe_store_->get(kf.id);
                                ++step_times_.keyframe_loads;
                                step_times_.keyframe_load_ms += ms_since(tl);
                                return images;
                              },
                              pixel_mask ? &*pixel_mask : nullptr};
    const LossTerms terms =
        backend_->step(slots, make_render_camera<float>(kf.camera, kf.pose), targets, config_.loss,
                       step_rates(kf.camera), prune ? &config_.prune : nullptr,
                       to_prune_);
    step_times_.backend_ms += ms_since(t1);
    t2 = clock::now();
    if (!std::isfinite(terms.total) && nonfinite_losses_++ == 0)
      log::warn("keyframe ", kf.id, ": a step's loss is not finite (", terms.total, ", L1 ", terms.l1, ", SSIM ",
                terms.ssim, ", depth ", terms.depth, "): the render or the target holds a non-finite value");
    st.loss = terms.total;
    st.rendered = slots.size();
    st.chunks = chunks.size();
    if (!slots.empty()) residency_->mark_dirty(chunks);
    ++iterations_;
    if (!to_prune_.empty()) {
      // The backend names them by their place in the slot list, which tells their chunks at once. Looking
      // the slots up (a pool-sized byte map, one pass over every slot of the view) had made bookkeeping
      // 0.18-0.34 ms a step at ~820-870 k slots (its pruning steps ten times that, the device idle).
      const auto tb = clock::now();
      st.pruned = residency_->remove_written_slots(chunks, to_prune_);
      pruned_total_ += st.pruned;
      step_times_.prune_ms += ms_since(tb);
    }
  } catch (...) {
    residency_->unpin(chunks);
    throw;
  }
  residency_->unpin(chunks);
  // Only once the sampler has been idle that long: keyframes arriving at least that often are sampled
  // on arrival and their steps add nothing, so fast intakes keep their maps and budgets as they were.
  if (!part_of_view && !revisit && config_.sampler.resample_every > 0 &&
      iterations_ - steps_at_last_sampling_ >= uint64_t(config_.sampler.resample_every)) {
    steps_at_last_sampling_ = iterations_;
    resample(kf);
  }
  // A partial step's loss counts pixels it could not explain: not a measure of the keyframe.
  if (!part_of_view) selector_.report_loss(kf.id, st.loss);
  step_times_.bookkeeping_ms += ms_since(t2);
  ++step_times_.steps;
  step_times_.total_ms += ms_since(t0);
  return st;
}

}  // namespace chungs
