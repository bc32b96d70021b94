#include "chungs/mapping/refinement_plan.hpp"

#include <algorithm>
#include <functional>
#include <queue>
#include <utility>

#include "chungs/common/error.hpp"

namespace chungs {
namespace {

// floor(total * k / parts), in 128 bits: steps may be near 2^63 and k large, and the shares' sum must
// not drift.
uint64_t share(uint64_t total, uint64_t k, uint64_t parts) { return uint64_t((unsigned __int128)total * k / parts); }

}  // namespace

void PackedViews::add(const std::vector<ChunkCount>& view) {
  if (uint64_t(number_.size()) + view.size() > UINT32_MAX)
    fail("refinement plan: more than 2^32 - 1 chunks seen over all keyframes");
  for (const ChunkCount& c : view)  // before adding any: a refused view leaves no entry
    if (c.count > UINT32_MAX) fail("refinement plan: chunk ", c.id, " holds ", c.count, " Gaussians (over 2^32 - 1)");
  for (const ChunkCount& c : view) {
    const auto [it, fresh] = numbered_.try_emplace(c.id, uint32_t(ids_.size()));
    if (fresh) ids_.push_back(c.id);
    number_.push_back(it->second);
    count_.push_back(uint32_t(c.count));
  }
  start_.push_back(uint32_t(number_.size()));
}

std::vector<RefinementGroup> plan_refinement(const PackedViews& views, uint64_t fit, uint64_t steps) {
  if (fit == 0) fail("refinement plan: the share of the budget a group may fill is 0");
  const size_t total = views.size();
  // Who sees a chunk (the entries of its views, by chunk), so that a chunk joining a group updates only
  // the keyframes that see it.
  MappedVector<uint32_t> seen_start(views.chunks() + 1, 0);
  for (size_t k = 0; k < total; ++k)
    for (uint32_t e = views.begin(k); e < views.end(k); ++e) ++seen_start[views.number(e) + 1];
  for (size_t c = 0; c < views.chunks(); ++c) seen_start[c + 1] += seen_start[c];
  MappedVector<uint32_t> seen_by(seen_start.back());  // keyframes; the count is the entry's
  MappedVector<uint32_t> seen_entry(seen_start.back());
  {
    MappedVector<uint32_t> fill(seen_start.begin(), seen_start.end() - 1);
    for (size_t k = 0; k < total; ++k)
      for (uint32_t e = views.begin(k); e < views.end(k); ++e) {
        const uint32_t at = fill[views.number(e)]++;
        seen_by[at] = uint32_t(k);
        seen_entry[at] = e;
      }
  }
  MappedVector<uint64_t> whole(total, 0);
  for (size_t k = 0; k < total; ++k)
    for (uint32_t e = views.begin(k); e < views.end(k); ++e) whole[k] += views.count(e);
  MappedVector<uint64_t> more = whole;  // what keyframe k would add to the group being built
  MappedVector<char> taken(total, 0), touched(total, 0), held(views.chunks(), 0);
  MappedVector<size_t> touched_list;
  MappedVector<uint32_t> held_list;
  using Entry = std::pair<uint64_t, size_t>;  // (more, keyframe): stale entries are skipped when popped
  std::priority_queue<Entry, MappedVector<Entry>, std::greater<Entry>> heap;
  std::vector<RefinementGroup> groups;
  size_t earliest = 0, left = total;
  while (left > 0) {
    RefinementGroup group;
    uint64_t sum = 0;
    const auto take = [&](size_t k) {
      taken[k] = 1;
      --left;
      group.keyframes.push_back(k);
      for (uint32_t e = views.begin(k); e < views.end(k); ++e) {
        const uint32_t c = views.number(e);
        if (held[c]) continue;
        held[c] = 1;
        held_list.push_back(c);
        sum += views.count(e);
        for (uint32_t s = seen_start[c]; s < seen_start[c + 1]; ++s) {
          const size_t j = seen_by[s];
          if (taken[j]) continue;
          if (!touched[j]) touched_list.push_back(j);
          touched[j] = 1;
          more[j] -= views.count(seen_entry[s]);
          // The group only grows: a keyframe that does not fit now fits later only by a chunk joining
          // that it sees, which comes back here. Fewer entries: a group of one view in a crowded
          // place (100 k budget, loops) would push every neighbour at every chunk.
          if (sum + more[j] <= fit) heap.push({more[j], j});
        }
      }
    };
    while (taken[earliest]) ++earliest;
    take(earliest);
    for (;;) {
      while (earliest < total && taken[earliest]) ++earliest;
      if (earliest < total) heap.push({more[earliest], earliest});
      while (!heap.empty() && (taken[heap.top().second] || heap.top().first != more[heap.top().second]))
        heap.pop();
      if (heap.empty() || sum + heap.top().first > fit) break;
      const size_t k = heap.top().second;
      heap.pop();
      take(k);
    }
    for (size_t j : touched_list) {
      more[j] = whole[j];
      touched[j] = 0;
    }
    touched_list.clear();
    for (uint32_t c : held_list) held[c] = 0;
    held_list.clear();
    heap = {};
    groups.push_back(std::move(group));
  }
  size_t before = 0;
  for (RefinementGroup& g : groups) {
    g.steps = share(steps, before + g.keyframes.size(), total) - share(steps, before, total);
    before += g.keyframes.size();
  }
  return groups;
}

std::vector<RefinementVisit> refinement_visits(const std::vector<RefinementGroup>& groups, size_t rounds,
                                              uint64_t min_visit_steps) {
  if (rounds == 0) fail("refinement plan: the number of rounds over the groups is 0");
  if (min_visit_steps == 0) fail("refinement plan: the fewest steps of a visit is 0");
  // The visits are listed whole, so their count is held to kMaxVisits: past it (a refinement of
  // millions of steps) visits grow longer than a pass over their group instead.
  constexpr uint64_t kMaxVisits = uint64_t(1) << 20;
  const uint64_t most_rounds = std::max<uint64_t>(rounds, kMaxVisits / std::max<size_t>(1, groups.size()));
  const auto wanted = [&](const RefinementGroup& g) {
    const uint64_t s = g.steps, pass = std::max<size_t>(1, g.keyframes.size());
    const uint64_t passes = s / pass + (s % pass != 0);
    return std::min(std::max(std::clamp<uint64_t>(s / min_visit_steps, 1, rounds), passes), most_rounds);
  };
  uint64_t all_rounds = rounds;
  for (const RefinementGroup& g : groups) all_rounds = std::max(all_rounds, wanted(g));
  std::vector<RefinementVisit> visits;
  for (uint64_t r = 0; r < all_rounds; ++r)
    for (size_t g = 0; g < groups.size(); ++g) {
      const uint64_t s = groups[g].steps;
      const uint64_t visits_g = wanted(groups[g]);
      const uint64_t j = share(visits_g, r, all_rounds);
      if (share(visits_g, r + 1, all_rounds) == j) continue;  // not visited in this round
      const uint64_t steps = share(s, j + 1, visits_g) - share(s, j, visits_g);
      if (steps > 0) visits.push_back({g, steps});
    }
  return visits;
}

}  // namespace chungs
