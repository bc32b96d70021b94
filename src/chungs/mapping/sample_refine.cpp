#include "chungs/mapping/sample_refine.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

namespace chungs {

void refine_sampled_depths(const Camera& camera, const SE3& pose, uint32_t id,
                           const std::vector<KeyframeRecord>& keyframes, KeyframeStore& images,
                           const MultiviewDepthConfig& config, double inv_range, bool cuda,
                           std::vector<PixelDepth>& pixels, SampleRefineTotals& totals) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<float> z;
  for (const PixelDepth& p : pixels)
    if (p.depth > 0 && std::isfinite(p.depth)) z.push_back(p.depth);
  if (z.empty()) return;
  ++totals.samplings;
  std::vector<const KeyframeRecord*> candidates;
  for (auto it = keyframes.rbegin(); it != keyframes.rend() && candidates.size() < size_t(config.keep_keyframes); ++it)
    if (it->id != id && it->camera.width == camera.width && it->camera.height == camera.height)
      candidates.push_back(&*it);
  std::vector<SE3> poses{pose};
  for (const KeyframeRecord* k : candidates) poses.push_back(k->pose);
  NeighbourChoice choice = config.choice;
  choice.count = config.refine_neighbours;
  // The pixels' own depths say where the triangulation angle matters (no guess at a scene depth).
  std::nth_element(z.begin(), z.begin() + long(z.size() / 2), z.end());
  choice.scene_depth = double(z[z.size() / 2]);
  const std::vector<size_t> chosen = select_sweep_neighbours(camera, poses, 0, choice);
  auto elapsed = [&] { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count(); };
  if (chosen.empty()) {
    ++totals.without_neighbour;
    totals.ms += elapsed();
    return;
  }
  std::vector<KeyframeStore::Images> held;  // keeps the neighbours' images alive
  PlaneSweepInput in;
  in.camera = camera;
  const std::shared_ptr<const KeyframeImages> ref = images.get(id);
  in.reference = {&ref->color, pose};
  for (size_t k : chosen) {
    held.push_back(images.get(candidates[k - 1]->id));
    in.neighbours.push_back({&held.back()->color, poses[k]});
  }
  PlaneSweepConfig sweep = config.sweep;
  sweep.cuda = cuda;
  const DepthRefineStats s = refine_depths(in, pixels, inv_range, sweep);
  totals.asked += s.asked;
  totals.refined += s.refined;
  totals.ms += elapsed();
}

}  // namespace chungs
