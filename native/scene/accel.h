// Embree 3 accelerator: the only place Embree types appear (DESIGN.md).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/math.h"

namespace gp {

struct Mesh;
struct Material;

struct RawHit {
  float t = kInfinity, u = 0, v = 0;
  Vec3 ng;  // unnormalised geometric normal as Embree reports it
  int geom = -1, prim = -1;
};

// Copies of the rays traced while it is installed, so a benchmark can replay an integrator's
// exact rays through raw Embree. Off (one relaxed atomic load per ray) unless installed.
struct RayRecorder {
  std::vector<Ray> closest, shadow;
  size_t limit = 1 << 22;  // per kind
};

class Accelerator {
 public:
  // With materials, triangles whose material is not visible to the camera are skipped by
  // camera rays, those hidden from a kind of bounce ray (Material::visible_lobes) by rays of
  // that Ray::bounce, and those that cast no shadow by occluded() (Embree filter functions,
  // installed only on the meshes that have such triangles).
  explicit Accelerator(const std::vector<Mesh>& meshes, const std::vector<Material>* materials = nullptr);
  ~Accelerator();
  Accelerator(const Accelerator&) = delete;
  Accelerator& operator=(const Accelerator&) = delete;

  // Replaces mesh `index`'s geometry (its vertices, winding or ray visibility changed); the
  // scene's BVH is rebuilt at commit(), the other meshes' buffers are kept as they are.
  void replace_mesh(size_t index, const Mesh& mesh, const std::vector<Material>* materials);
  void commit();

  bool intersect(const Ray& ray, RawHit& hit) const;
  bool occluded(const Ray& ray) const;
  // The same queries for n rays at once through Embree's stream interface (rtcIntersect1M,
  // rtcOccluded1M): found[i] / blocked[i] and hits[i] as intersect() / occluded() of rays[i].
  // Embree may regroup the rays into packets; `coherent` says they start near each other in
  // similar directions (camera rays of one tile), which lets it. For benchmarks and for
  // integrators that trace rays in batches; thread-safe, no allocation after a thread's first.
  void intersect_stream(const Ray* rays, size_t n, RawHit* hits, bool* found, bool coherent = false) const;
  void occluded_stream(const Ray* rays, size_t n, bool* blocked, bool coherent = false) const;
  // Installs (or with nullptr removes) the recorder for all threads; not re-entrant.
  static void record_rays(RayRecorder* recorder);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gp
