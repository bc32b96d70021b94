// A renderable world: hands the rasterizer the meshes near a camera, so that a 10 km world renders
// only what lies within the far plane.
#pragma once
#include <vector>

#include "chungs/geometry/camera.hpp"
#include "chungs/geometry/se3.hpp"
#include "chungs/synth/materials.hpp"
#include "chungs/synth/mesh.hpp"

namespace chungs::synth {

class Scene {
 public:
  virtual ~Scene() = default;
  // Meshes that may be seen from camera-to-world pose T_wc within `far` metres. The pointers stay
  // valid until the next call.
  virtual std::vector<const Mesh*> gather(const Camera& cam, const SE3& T_wc, double far) = 0;
  virtual const Environment& environment() const = 0;
  // Triangles held in memory now.
  virtual size_t triangles() const = 0;
};

// A fixed set of meshes (a room, a scanned mesh), culled per mesh by bounding box.
class MeshScene : public Scene {
 public:
  MeshScene(std::vector<Mesh> meshes, const Environment& env) : meshes_(std::move(meshes)), env_(env) {}
  std::vector<const Mesh*> gather(const Camera& cam, const SE3& T_wc, double far) override;
  const Environment& environment() const override { return env_; }
  size_t triangles() const override;
  const std::vector<Mesh>& meshes() const { return meshes_; }

 private:
  std::vector<Mesh> meshes_;
  Environment env_;
};

// True when the world box [lo, hi] may intersect the view pyramid of the camera up to `far`.
bool box_maybe_visible(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Camera& cam, const SE3& T_wc,
                       double far);

}  // namespace chungs::synth
