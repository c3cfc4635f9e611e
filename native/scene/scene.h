// Scene: triangle meshes, the closed material set, lights and the camera, plus the
// acceleration structure built by finalize(). Integrators see only these types; Embree stays
// behind scene/accel.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/frame.h"
#include "core/log.h"
#include "core/math.h"
#include "lights/light.h"
#include "materials/bsdf.h"
#include "materials/material.h"
#include "scene/camera.h"

namespace gp {

class Accelerator;

struct Mesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;           // optional per-vertex shading normals (empty = flat)
  std::vector<Vec2> uvs;               // optional per-vertex UVs
  std::vector<uint32_t> indices;       // 3 per triangle
  std::vector<uint32_t> material_ids;  // 1 per triangle, index into Scene::materials
  size_t triangle_count() const { return indices.size() / 3; }
};

// A ray's closest hit with everything shading needs.
struct SurfaceHit {
  float t = kInfinity;
  Vec3 p;
  Vec3 ng;        // unit geometric normal (triangle winding)
  Vec3 ns;        // unit shading normal, on the same side as ng
  Vec2 uv;
  Frame frame;    // shading frame around ns
  int mesh = -1, prim = -1;
  int material = -1;
  int light = -1; // area light index of this triangle, or -1
};

// Ray origin pushed off a surface so the next ray does not re-hit it ("A Fast and Robust
// Method for Avoiding Self-Intersection", Wächter & Binder, Ray Tracing Gems ch. 6).
Vec3 offset_ray_origin(const Vec3& p, const Vec3& ng, const Vec3& w);

class Scene {
 public:
  Scene();
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Light> lights;  // non-area lights from the scene description
  Camera camera;
  std::string source;         // file the scene came from (for messages)
  Warnings warnings;          // counted load warnings

  // Validates, builds area lights from emissive triangles, the light distribution and the
  // accelerator. Throws std::runtime_error naming the object at fault.
  void finalize();
  bool finalized() const { return accel_ != nullptr; }

  std::optional<SurfaceHit> intersect(const Ray& ray) const;
  bool occluded(const Ray& ray) const;
  // Shadow ray between two surface points, both pushed off their surfaces.
  bool occluded_between(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1) const;
  // Shadow ray from surface point p (geometric normal ng) to a light sample: to its point for
  // area lights, else along wi up to just short of the light (or to infinity).
  bool occluded(const Vec3& p, const Vec3& ng, const LightSample& ls) const;

  const LightSet& light_set() const { return light_set_; }
  const Bounds3& bounds() const { return bounds_; }
  size_t triangle_count() const;
  const Material& material(int i) const { return materials[i]; }
  // The BSDF at a surface point: its material with the textures looked up at its uv. Every
  // integrator shades through these, so the photon and gradient methods see the same textures.
  Bsdf bsdf(const SurfaceHit& h) const {
    Bsdf b(materials[h.material], h.uv);
    if (materials[h.material].perturbs_normal()) b.set_geometric_normal(h.frame.to_local(h.ng));
    return b;
  }
  Bsdf bsdf(int material, Vec2 uv) const { return Bsdf(materials[material], uv); }
  // The texture coordinate at point p of a triangle (a vertex a manifold walk moved).
  Vec2 uv_at(int mesh, int prim, const Vec3& p) const;
  // The raw accelerator, for benchmarks that measure Embree without shading.
  const Accelerator& accelerator() const { return *accel_; }

 private:
  std::unique_ptr<Accelerator> accel_;
  LightSet light_set_;
  Bounds3 bounds_;
  std::vector<std::vector<int32_t>> triangle_light_;  // per mesh, per triangle: light or -1
};

}  // namespace gp
