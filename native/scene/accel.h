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
  Vec3 ng;  // unnormalised geometric normal as Embree reports it (object space for a moved mesh)
  int geom = -1, prim = -1;  // mesh index (moved or not) and triangle
  float time = 0;            // the ray's shutter time (Ray::time): where a moving mesh was hit
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

  // Two levels once something moves (Embree's instancing): until a mesh first moves, all meshes
  // are triangles of one flat BVH (the fastest to trace). Its first move_mesh takes it out into a
  // BVH of its own in object space (mesh.source), instanced into the top level under its
  // to_world, and puts the meshes never moved into one more such BVH (instanced unmoved); a later
  // move only sets the instance's matrix, so commit() rebuilds just the top level over a few
  // instances. Hits report the mesh index as `geom` either way.
  void move_mesh(size_t index, const Mesh& mesh, const std::vector<Material>* materials);
  // Replaces mesh `index`'s geometry (its ray visibility changed) where it is now: in the flat
  // BVH, among the unmoved meshes or in its own BVH; the other meshes' buffers are kept.
  void replace_mesh(size_t index, const Mesh& mesh, const std::vector<Material>* materials);
  // Builds what changed since the last commit: the changed lower-level BVHs, then the top level.
  void commit();
  // Whether mesh `index` is traced through an instance (it has moved), for tests.
  bool instanced(size_t index) const;

  bool intersect(const Ray& ray, RawHit& hit) const;
  bool occluded(const Ray& ray) const;
  // Cycles' transparent shadows (kernel/integrator/intersect_shadow.h): whether a surface that
  // is neither transparent to shadows (Material::transparent_shadow) nor casting no shadow
  // blocks the ray; *crossed says whether it met a transparent one on the way (only then need
  // the caller find them: intersect_shadow). One any-hit query, as occluded().
  bool occluded_opaque(const Ray& ray, bool* crossed) const;
  // The closest surface a shadow ray meets, surfaces that cast no shadow let through.
  bool intersect_shadow(const Ray& ray, RawHit& hit) const;
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
