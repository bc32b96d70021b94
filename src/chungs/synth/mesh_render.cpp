#include "chungs/synth/mesh_render.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "chungs/common/error.hpp"
#include "chungs/common/log.hpp"
#include "chungs/common/output_paths.hpp"
#include "chungs/image/image_io.hpp"
#include "chungs/synth/ply.hpp"

namespace chungs::synth {
namespace fs = std::filesystem;

namespace {
// An image side read as a number: whole and within what the renderer allocates, checked before the
// cast to int (1e12 used to wrap to a negative size, 100000 x 100000 to a failed allocation).
int image_side(double v, const std::string& where, const char* what) {
  if (!(v >= 1 && v <= kMaxImageSide) || v != std::floor(v))
    fail(where, ": ", what, " must be a whole number of pixels from 1 to ", kMaxImageSide, ", got ", v);
  return int(v);
}
}  // namespace

Camera read_cam_params_json(const fs::path& file, double* depth_scale) {
  require_file(file, "camera parameters");
  std::ifstream in(file);
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    fail(file, ": not valid JSON (", e.what(), ")");
  }
  const auto& c = j.contains("camera") ? j["camera"] : j;
  auto num = [&](const char* key) {
    if (!c.contains(key) || !c[key].is_number()) fail(file, ": missing number camera.", key);
    return c[key].get<double>();
  };
  Camera cam(image_side(num("w"), file.string(), "camera.w"), image_side(num("h"), file.string(), "camera.h"),
             num("fx"), num("fy"), num("cx"), num("cy"));
  cam.validate(file.string());
  if (depth_scale) *depth_scale = c.contains("scale") && c["scale"].is_number() ? c["scale"].get<double>() : 0;
  return cam;
}

Camera parse_intrinsics(const std::string& spec) {
  if (spec.empty()) fail("intrinsics are empty: give fx,fy,cx,cy,width,height or a cam_params.json");
  if (spec.find(',') == std::string::npos) return read_cam_params_json(spec);
  std::vector<double> v;
  std::stringstream ss(spec);
  std::string tok;
  // getline drops a last empty field: "...,48," would pass as six numbers.
  if (!spec.empty() && spec.back() == ',') fail("intrinsics '", spec, "': ends with a comma");
  while (std::getline(ss, tok, ',')) {
    char* end = nullptr;
    double x = std::strtod(tok.c_str(), &end);
    if (tok.empty() || *end != '\0') fail("intrinsics '", spec, "': '", tok, "' is not a number");
    v.push_back(x);
  }
  if (v.size() != 6) fail("intrinsics '", spec, "': expected fx,fy,cx,cy,width,height (6 numbers), got ", v.size());
  const std::string where = "intrinsics '" + spec + "'";
  Camera cam{image_side(v[4], where, "width"), image_side(v[5], where, "height"), v[0], v[1], v[2], v[3]};
  cam.validate("intrinsics '" + spec + "'");
  return cam;
}

SequenceReport render_mesh_sequence(const MeshSequenceSpec& spec) {
  if (spec.every == 0) fail("--every must be at least 1");
  // The sequence replaces its folder's frames, trajectory and calibration: an input inside it could be
  // one of them (--traj X/poses.txt --out X was rewritten as the new sequence's 3 poses).
  for (const auto& [input, flag] : {std::pair{spec.traj, "--traj"}, std::pair{spec.mesh, "--mesh"}})
    if (lies_within(input, spec.out))
      fail(input.string(), ": the ", flag, " file lies in the output folder ", spec.out.string(),
           ", which the sequence writes; give another --out");
  Trajectory full = read_trajectory(spec.traj, spec.rate_hz);
  Trajectory traj;
  for (size_t i = 0; i < full.size(); i += spec.every) {
    if (spec.max_frames && traj.size() >= spec.max_frames) break;
    traj.push_back(full.stamps[i], full.poses[i]);
  }
  if (traj.empty()) fail(spec.traj, ": no poses");
  log::info("reading mesh ", spec.mesh.string());
  std::vector<Mesh> meshes;
  meshes.push_back(read_ply(spec.mesh));
  log::info("mesh: ", meshes[0].vertices.size(), " vertices, ", meshes[0].triangles(), " triangles; ", traj.size(),
            " frames, camera ", spec.camera.describe());
  MeshScene scene(std::move(meshes), Environment::indoor());
  return render_sequence(scene, traj, spec.camera, spec.seq, spec.out);
}

Office0Check check_office0(const fs::path& data) {
  const fs::path mesh_file = data / "office0_mesh.ply", cam_file = data / "cam_params.json",
                 traj_file = data / "office0" / "traj.txt",
                 depth_file = data / "office0" / "results" / "depth000000.png";
  require_dir(data, "replica_office0 data folder");
  for (const auto& f : {mesh_file, cam_file, traj_file, depth_file}) require_file(f);
  double scale = 0;
  const Camera cam = read_cam_params_json(cam_file, &scale);
  if (!(scale > 0)) fail(cam_file, ": camera.scale (depth units per metre) must be positive");
  const Trajectory traj = read_trajectory(traj_file, 30.0);
  if (traj.empty()) fail(traj_file, ": no poses");
  const Mesh mesh = read_ply(mesh_file);
  const Image16 real = read_png16(depth_file);
  if (real.width() != cam.width || real.height() != cam.height)
    fail(depth_file, ": size ", real.width(), "x", real.height(), " differs from the camera's ", cam.width, "x",
         cam.height);

  Office0Check out;
  out.triangles = mesh.triangles();
  Rasterizer r;
  ImageF rgb, depth;
  RenderOptions opt;
  opt.color = false;
  const auto t0 = std::chrono::steady_clock::now();
  r.render({&mesh}, cam, traj.poses[0], Environment::indoor(), opt, rgb, depth);
  out.render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<double> diffs;
  out.pixels = depth.pixels();
  for (size_t i = 0; i < depth.pixels(); ++i) {
    const double a = depth.data()[i], b = real.data()[i] / scale;
    if (a > 0 && b > 0) diffs.push_back(std::abs(a - b));
  }
  out.valid_pixels = diffs.size();
  if (diffs.empty()) fail("office0 check: no pixel has depth in both the render and ", depth_file);
  double sum = 0;
  for (double d : diffs) sum += d;
  out.mean_abs_diff = sum / double(diffs.size());
  std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
  out.median_abs_diff = diffs[diffs.size() / 2];
  return out;
}

}  // namespace chungs::synth
