#include "chungs/pipeline/render_poses.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "chungs/common/log.hpp"
#include "chungs/common/output_paths.hpp"
#include "chungs/common/progress.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/mapping/mapper.hpp"
#include "chungs/mapping/sky_file.hpp"
#include "chungs/pipeline/evaluation.hpp"
#include "chungs/pipeline/frame_source.hpp"
#include "chungs/render/cpu/rasterizer.hpp"
#include "chungs/render/gaussian_view.hpp"
#include "chungs/render/render_camera.hpp"
#include "chungs/render/render_passes.hpp"
#include "chungs/residency/budget_groups.hpp"
#include "chungs/residency/frustum_culler.hpp"
#include "chungs/residency/residency.hpp"
#include "chungs/store/chunk_levels.hpp"
#include "chungs/store/map_folder.hpp"

namespace chungs {

namespace fs = std::filesystem;

namespace {
// The map's chunks are drawn at the levels its own far-level distance chose.
CullerConfig with_map_levels(CullerConfig c, const ChunkStore& store) {
  c.far_level_distance = map_far_level_distance(store);
  return c;
}
}  // namespace

struct MapRenderer::Impl {
  ChunkStore store;
  CpuGaussianPool pool;
  Residency residency;
  FrustumCuller culler;
  CpuRasterizer<float> raster;
  std::optional<SkyTexture> sky;  // the map's sky.bin, when it has one
  ImageF sky_px;
  std::array<double, 3> background;
  std::vector<uint32_t> slots;  // of the chunks drawn
  Impl(const fs::path& folder, const Config& c)
      : store(folder, reader_config(c.store)),  // rendering never repairs or rewrites the map
        pool(c.residency.budget_gaussians, store.sh_degree()),
        residency(store, pool, c.residency),
        culler(store.chunk_size(), with_map_levels(c.culling, store)),
        raster(c.raster),
        background(c.raster.background) {}
};

const fs::path& MapRenderer::folder() const { return impl_->store.folder(); }

MapRenderer::MapRenderer(const fs::path& folder, const Config& config) {
  require_map_manifest(folder);
  // The camera and sky of the checkpoint the manifest names, even where its run failed before they
  // took their final names: a reader renames nothing. A mapper may be running: it renames them
  // after its commit, so a numbered file can vanish between looking and reading (then the final
  // name holds it), and the final name holds the next checkpoint's once that one is committed,
  // which the manifest, read again afterwards, tells: then the whole read starts over.
  auto checkpoint_of = [](const std::optional<std::string>& tag) {
    return tag ? std::strtoull(tag->c_str(), nullptr, 10) : 0ull;
  };
  auto read_committed = [&](uint64_t seq, const std::string& name, auto&& read) {
    const fs::path pending = checkpoint_file(folder, seq, name);
    if (seq > 0 && fs::exists(pending)) try {
        read(pending);
        return;
      } catch (const Error&) {
        if (fs::exists(pending)) throw;
      }
    if (fs::exists(folder / name)) read(folder / name);
  };
  // A read of the keyframe list and sky must fit between two commits; on a loaded machine beside a
  // mapper that commits every few keyframes, a fair share of attempts do not (5 gave up in a test run).
  constexpr int kAttempts = 20;
  for (int attempt = 1;; ++attempt) {
    impl_ = std::make_unique<Impl>(folder, config);
    keyframes_.clear();
    const uint64_t seq = checkpoint_of(impl_->store.config_value("checkpoint"));
    read_committed(seq, "keyframes.txt", [&](const fs::path& f) { keyframes_ = read_keyframe_records(f); });
    read_committed(seq, "sky.bin", [&](const fs::path& f) { impl_->sky = read_sky_file(f); });
    const Manifest now = Manifest::read(folder / "manifest.txt");
    const auto tag = now.config.find("checkpoint");
    if (checkpoint_of(tag == now.config.end() ? std::nullopt : std::optional(tag->second)) == seq) break;
    if (attempt == kAttempts) fail(folder.string(), ": the map changed faster than it could be read; try again");
    log::info(folder.string(), ": the map was committed again while it was read; reading the new commit");
  }
}

MapRenderer::~MapRenderer() = default;

const Camera& MapRenderer::mapping_camera() const {
  if (keyframes_.empty()) {
    const fs::path folder = impl_->store.folder();
    fail("map ", folder.string(), fs::exists(folder / "keyframes.txt") ? ": keyframes.txt lists no keyframe" : ": no keyframes.txt",
         ", so no camera to render with");
  }
  return keyframes_.front().camera;
}

uint64_t MapRenderer::total_gaussians() const {
  uint64_t n = 0;
  for (const auto& kv : impl_->residency.catalogue()) n += kv.second;
  return n;
}
std::pair<ChunkId, uint64_t> MapRenderer::largest_chunk() const {
  std::pair<ChunkId, uint64_t> largest{0, 0};
  for (const auto& [id, n] : impl_->residency.catalogue())
    if (n > largest.second || (n == largest.second && n > 0 && id < largest.first)) largest = {id, n};
  return largest;
}
size_t MapRenderer::peak_resident_gaussians() const { return impl_->residency.peak_resident_gaussians(); }
size_t MapRenderer::budget() const { return impl_->residency.budget(); }
IoStats MapRenderer::io_stats() const { return impl_->residency.stats(); }

RenderOutput<float> MapRenderer::render(const Camera& camera, const SE3& pose) {
  Residency& res = impl_->residency;
  impl_->culler.set_chunks_from(res.catalogue(), res.catalogue_version());
  const std::vector<ChunkCount> near =
      nearest_first(impl_->culler.cull(camera, pose), res, impl_->store.chunk_size(), pose.t);
  uint64_t visible = 0;
  for (const ChunkCount& c : near) visible += c.count;
  largest_view_ = std::max(largest_view_, visible);
  // A view beyond the budget is drawn in passes of chunks that fit, nearest first (render_passes.hpp).
  const BudgetGroups groups = split_by_budget(near, res.budget());
  skipped_ += groups.too_large.size();
  if (groups.groups.size() > 1) ++in_passes_;
  const RenderCamera<float> rc = make_render_camera<float>(camera, pose);
  const auto draw = [&](const std::vector<ChunkId>& chunks) {
    return with_pinned_slots(res, chunks, impl_->slots, "render", [&](const std::vector<uint32_t>& slots) {
      return impl_->raster.forward(view_of(impl_->pool.params()), slots, rc);
    });
  };
  RenderOutput<float> out =
      groups.groups.empty() ? draw({}) : render_front_to_back(groups.groups, draw, impl_->background);
  if (impl_->sky) {
    sky_colours(*impl_->sky, rc, impl_->sky_px);
    compose_sky(impl_->sky_px, out.alpha, out.rgb);
  }
  ++views_;
  return out;
}

std::string map_poses_source(const fs::path& folder) {
  const fs::path f = folder / "run_state.json";
  if (!fs::exists(f)) return {};
  const nlohmann::json j = read_json_file(f);
  validate_run_state(j, f);
  return j.value("poses", std::string());
}

size_t map_budget_from_report(const fs::path& folder) {
  const fs::path f = folder / "report.json";
  if (!fs::exists(f)) return 0;
  const nlohmann::json j = read_json_file(f);
  if (!j.is_object()) fail(f.string(), ": not a run report (a JSON object), got ", j.type_name());
  if (!j.contains("settings")) return 0;
  const nlohmann::json& s = j["settings"];
  if (!s.is_object()) fail(f.string(), ": 'settings' must be an object, got ", s.dump());
  if (!s.contains("budget_gaussians")) return 0;
  // Checked here, naming the file: json's get<size_t>() wraps -5 to 2^64 - 5 and truncates 1.5, and
  // a budget beyond the pool's slots ended in a bare type_error or "vector larger than max_size()".
  const nlohmann::json& b = s["budget_gaussians"];
  if (!b.is_number_unsigned() || b.get<uint64_t>() < 1 || b.get<uint64_t>() > GaussianPool::kMaxCapacity)
    fail(f.string(), ": 'settings.budget_gaussians' must be a whole number in [1, ",
         GaussianPool::kMaxCapacity, "], got ", b.dump());
  return b.get<size_t>();
}

nlohmann::json RenderPosesSummary::to_json() const {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& v : views) {
    nlohmann::json e = {{"index", v.index}};
    if (v.metrics) {
      e["psnr"] = v.metrics->psnr;
      e["ssim"] = v.metrics->ssim;
    }
    a.push_back(e);
  }
  nlohmann::json j = {{"rendered", views.size()}, {"seconds", seconds}, {"views", a}};
  if (scored) {
    j["scored"] = scored;
    j["mean_psnr"] = mean_psnr;
    j["mean_ssim"] = mean_ssim;
  }
  return j;
}

namespace {

using Clock = std::chrono::steady_clock;

// A render's file, never one of the map's: a link left in the output folder (render_000000.png ->
// MAP/manifest.txt) made a render replace the map's manifest.
fs::path png_name(const MapRenderer& renderer, const fs::path& out, size_t index) {
  char name[48];
  std::snprintf(name, sizeof name, "render_%06zu.png", index);
  const fs::path file = out / name;
  if (lies_within(file, renderer.folder()))
    fail(file.string(), ": leads into the map folder ", renderer.folder().string(), "; a render never writes there");
  return file;
}

ImageF clamped_rgb(const RenderOutput<float>& r) {
  ImageF img = r.rgb;
  for (auto& v : img.vec()) v = std::clamp(v, 0.f, 1.f);  // what an 8-bit render shows
  return img;
}

void finish(RenderPosesSummary& s, Clock::time_point t0) {
  for (const auto& v : s.views)
    if (v.metrics) {
      s.mean_psnr += v.metrics->psnr;
      s.mean_ssim += v.metrics->ssim;
      ++s.scored;
    }
  if (s.scored) {
    s.mean_psnr /= double(s.scored);
    s.mean_ssim /= double(s.scored);
  }
  s.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

RenderPosesSummary render_trajectory(MapRenderer& renderer, const Trajectory& traj, const Camera& camera,
                                     const fs::path& out, size_t stride) {
  if (stride == 0) fail("render: stride must be positive");
  camera.validate("render camera");
  fs::create_directories(out);
  const auto t0 = Clock::now();
  RenderPosesSummary s;
  Progress progress("rendering", (long long)((traj.size() + stride - 1) / stride));
  for (size_t i = 0; i < traj.size(); i += stride) {
    progress.step();
    write_png(png_name(renderer, out, i), to_u8(clamped_rgb(renderer.render(camera, traj.poses[i]))));
    s.views.push_back({i, std::nullopt});
  }
  progress.finish();
  finish(s, t0);
  return s;
}

RenderPosesSummary render_dataset(MapRenderer& renderer, const Dataset& dataset,
                                  const std::vector<std::optional<SE3>>& poses, double resolution,
                                  const fs::path& out, size_t stride, bool stack) {
  if (stride == 0) fail("render: stride must be positive");
  if (!(resolution > 0 && resolution <= 1)) fail("render: resolution must be in (0, 1], got ", resolution);
  fs::create_directories(out);
  const auto t0 = Clock::now();
  RenderPosesSummary s;
  const size_t n = std::min(poses.size(), dataset.size());
  Progress progress("rendering", (long long)((n + stride - 1) / stride));
  for (size_t i = 0; i < n; i += stride) {
    progress.step();
    if (!poses[i]) continue;
    const MappingFrame m = load_mapping_frame(dataset, i, resolution, DepthMode::None, {}, false);
    const ImageF render = clamped_rgb(renderer.render(m.frame.camera, *poses[i]));
    const ImageF ref = to_rgb_float(m.frame.left);
    s.views.push_back({i, compare_images(ref, render)});
    write_png(png_name(renderer, out, i), stack ? stack_vertically(render, ref) : to_u8(render));
  }
  progress.finish();
  finish(s, t0);
  return s;
}

}  // namespace chungs
