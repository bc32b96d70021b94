// Writes the seed corpora of the binary and map-folder targets with the project's own writers, so
// that seeds follow the formats when they change: `fuzz_make_seeds fuzz/corpus` (built on demand in
// build-fuzz). The dataset and YAML seeds are excerpts of real files and need no program.
#include <cstdio>
#include <filesystem>

#include "chungs/image/image_io.hpp"
#include "chungs/mapping/map_state.hpp"
#include "chungs/mapping/sky_file.hpp"
#include "chungs/pipeline/timeline.hpp"
#include "chungs/store/chunk_file.hpp"
#include "chungs/store/keyframe_file.hpp"
#include "chungs/store/manifest.hpp"

namespace fs = std::filesystem;
using namespace chungs;

namespace {

// Values of every sign and a spread of magnitudes, so that the half-precision scales and the
// byte shuffle see what trained maps hold; a fixed recurrence keeps the seeds reproducible.
float value(size_t i) {
  const float x = float((i * 2654435761u) % 2000) / 1000.0f - 1.0f;
  return x * float(1 << (i % 7));
}

GaussianBlock block(size_t n, int sh_degree) {
  GaussianBlock b;
  b.sh_degree = sh_degree;
  b.resize(n);
  size_t k = 0;
  for (GaussianParams* p : {&b.params, &b.adam_m, &b.adam_v})
    for (auto* a : {&p->mean, &p->log_scale, &p->rotation, &p->opacity, &p->sh})
      for (float& v : *a) v = value(k++);
  for (float& v : b.adam_v.sh) v = v * v;
  for (size_t i = 0; i < n; ++i) {
    b.adam_steps[i] = uint32_t(3 + i);
    b.created_by_keyframe[i] = uint32_t(i / 2);
    b.created_at_step[i] = uint32_t(100 * i);
    b.lr_position_factor[i] = 1.0f / float(1 + i);
  }
  return b;
}

void chunks(const fs::path& dir) {
  ChunkWriteOptions o;
  o.durable = false;
  write_chunk_file(dir / "full_raw", 7, block(3, 3), o);
  o.compress = true;
  write_chunk_file(dir / "full_zstd_shuffled", 8, block(4, 3), o);
  o.compress = false;
  o.half_moments = true;
  write_chunk_file(dir / "half_moments_raw", 9, block(3, 1), o);
  o.compress = true;
  o.half_sh_rest = true;
  write_chunk_file(dir / "half_both_zstd", 10, block(3, 3), o);
}

void keyframes(const fs::path& dir) {
  KeyframeImages im;
  im.color = Image8(8, 6, 3);
  im.depth = ImageF(8, 6, 1);
  for (size_t i = 0; i < im.color.size(); ++i) im.color.data()[i] = uint8_t(13 * i);
  for (size_t i = 0; i < im.depth.size(); ++i) im.depth.data()[i] = 1.0f + 0.01f * float(i);
  KeyframeWriteOptions o;
  o.durable = false;
  write_keyframe_file(dir / "color_depth_zstd", 4, im, o);
  im.depth = ImageF();
  im.color = Image8(5, 3, 1, 90);
  o.compress = false;
  write_keyframe_file(dir / "gray_raw", 5, im, o);
}

void sky(const fs::path& dir) {
  SkyTexture s;
  s.width = 4;
  s.height = 2;
  s.rgb.resize(24);
  s.m1.resize(24);
  s.m2.resize(24);
  s.updates.resize(8);
  for (size_t i = 0; i < 24; ++i) s.rgb[i] = 0.1f * float(i % 9), s.m1[i] = value(i) * 1e-3f, s.m2[i] = 1e-6f * float(i);
  for (size_t i = 0; i < 8; ++i) s.updates[i] = uint32_t(i * 5);
  write_sky_file(dir / "sky_4x2", s, false);
}

void manifest(const fs::path& dir) {
  Manifest m;
  m.chunk_size = 10;
  m.sh_degree = 3;
  m.next_generation = 4;
  m.config["store.compress"] = "true";
  m.config["dataset"] = "kitti:/data/kitti/sequences/00";
  m.chunks[chunk_id({0, 0, 0})] = {1200, 870000, 0x1234abcd5678ef01u, 2};
  m.chunks[chunk_id({-1, 0, 3})] = {35, 25400, 0x0fedcba987654321u, 3};
  m.write(dir / "two_chunks", false);
}

void run_state(const fs::path& dir) {
  std::vector<TimelineSample> timeline(2);
  timeline[1].seconds = 2.5, timeline[1].frame = 10, timeline[1].keyframes = 3, timeline[1].iterations = 900;
  const nlohmann::json j{{"dataset", "kitti:/data/kitti/sequences/00"},
                         {"poses", "tracker"},
                         {"next_frame", 11},
                         {"frames", 4541},
                         {"finished", false},
                         {"seconds", 2.5},
                         {"timeline", to_json(timeline)}};
  write_json_atomically(dir / "checkpoint", j, false);
}

void keyframe_list(const fs::path& dir) {
  std::vector<KeyframeRecord> r(2);
  for (size_t i = 0; i < r.size(); ++i) {
    r[i].id = uint32_t(i);
    r[i].frame = 5 * i;
    r[i].stamp = 0.5 * double(i);
    r[i].camera = Camera(620, 188, 359.4, 359.4, 303.0, 92.6);
    r[i].pose = SE3(Eigen::Quaterniond(0.98, 0.1, -0.1, 0.14).normalized(), Eigen::Vector3d(0.1, -0.2, 4.0 * double(i)));
    r[i].uses = int(3 + i);
    r[i].last_loss = 0.05;
  }
  write_keyframe_records(dir / "two_keyframes", r, false);
}

// Each encoding the reader has a branch for: grey, RGB and RGBA PNG, 16-bit depth PNG, grey and
// colour JPEG.
void images(const fs::path& dir) {
  for (int c : {1, 3, 4}) {
    Image8 im(7, 5, c);
    for (size_t i = 0; i < im.size(); ++i) im.data()[i] = uint8_t(29 * i);
    write_png(dir / cat("png8_", c, "ch"), im);
    if (c != 4) write_jpeg(dir / cat("jpeg_", c, "ch"), im, 90);
  }
  Image16 depth(6, 4, 1);
  for (size_t i = 0; i < depth.size(); ++i) depth.data()[i] = uint16_t(1000 + 977 * i);
  write_png(dir / "png16_depth", depth);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds CORPUS_FOLDER (fuzz/corpus)\n");
    return 2;
  }
  const fs::path root = argv[1];
  const std::pair<const char*, void (*)(const fs::path&)> makers[] = {
      {"chunk_file", chunks}, {"keyframe_file", keyframes}, {"sky_file", sky},
      {"manifest", manifest}, {"run_state", run_state},     {"keyframe_list", keyframe_list},
      {"image", images}};
  try {
    for (const auto& [name, make] : makers) {
      fs::create_directories(root / name);
      make(root / name);
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "fuzz_make_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
