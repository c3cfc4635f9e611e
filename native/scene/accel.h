// Embree 3 accelerator: the only place Embree types appear (DESIGN.md).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/math.h"

namespace gp {

struct Mesh;

struct RawHit {
  float t = kInfinity, u = 0, v = 0;
  Vec3 ng;  // unnormalised geometric normal as Embree reports it
  int geom = -1, prim = -1;
};

class Accelerator {
 public:
  explicit Accelerator(const std::vector<Mesh>& meshes);
  ~Accelerator();
  Accelerator(const Accelerator&) = delete;
  Accelerator& operator=(const Accelerator&) = delete;

  bool intersect(const Ray& ray, RawHit& hit) const;
  bool occluded(const Ray& ray) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gp
