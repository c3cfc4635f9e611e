// Motion blur's geometry over the shutter (scene-format "Motion blur"): transforms given at
// S >= 2 evenly spaced shutter times (step i at t = i / (S - 1), Embree's time steps),
// interpolated as Cycles interpolates object motion (util/transform.cpp transform_decompose,
// kernel/geom/object.h object_fetch_transform_motion): each matrix decomposed into translation,
// rotation quaternion and scale/shear, each part interpolated on its own (the quaternion by
// slerp), so a turning object keeps its size mid-shutter. The decomposition is the one Embree's
// rtcSetGeometryTransformQuaternion takes (p' = T R S p, S upper triangular), so that the
// accelerator's instances and the hits, lights and camera computed here move alike.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"

namespace gp {

struct DecomposedTransform {
  // S: upper triangular scale/shear (rows: s00 s01 s02 / 0 s11 s12 / 0 0 s22), the mirror sign in s22.
  float s00 = 1, s01 = 0, s02 = 0, s11 = 1, s12 = 0, s22 = 1;
  float qr = 1, qi = 0, qj = 0, qk = 0;  // unit rotation quaternion r + i i + j j + k k
  Vec3 translation;
};

// M = T R S (Gram-Schmidt QR of M's 3x3 part). M must be affine and invertible (check_object_matrix).
DecomposedTransform decompose(const Transform& m);
Transform compose(const DecomposedTransform& d);

// Transforms over the shutter: S >= 2 decomposed steps, consecutive quaternions on the same
// hemisphere (the shorter arc, as Cycles' transform_motion_decompose makes them).
class TransformMotion {
 public:
  TransformMotion() = default;
  explicit TransformMotion(const std::vector<Transform>& steps);
  bool empty() const { return steps_.empty(); }
  size_t size() const { return steps_.size(); }
  const std::vector<DecomposedTransform>& steps() const { return steps_; }
  // The transform at shutter time t in [0, 1] (clamped).
  Transform at(float t) const;
  // Whether every step is the same matrix (a "motion" that does not move).
  bool still() const;

 private:
  std::vector<DecomposedTransform> steps_;
};

// The step pair and weight of shutter time t among `steps` evenly spaced steps: t lies between
// step *i and *i + 1, `f` of the way (Embree's linear interpolation of time steps).
inline void motion_step(float t, size_t steps, size_t* i, float* f) {
  const float x = std::clamp(t, 0.0f, 1.0f) * static_cast<float>(steps - 1);
  size_t k = static_cast<size_t>(x);
  if (k >= steps - 1) k = steps - 2;
  *i = k;
  *f = x - static_cast<float>(k);
}

// A mesh over the shutter, shared by the mesh and its area lights: object-space vertices
// (`positions` at S' >= 2 steps for deformation, else the frame's `object_positions`) under the
// object-to-world transform (`transform` over the shutter, else the fixed `to_world`).
struct MeshMotion {
  TransformMotion transform;                     // empty: to_world throughout
  Transform to_world;
  std::vector<std::vector<Vec3>> positions;      // S' >= 2 object-space steps, or empty
  std::vector<Vec3> object_positions;            // the frame's object-space vertices
  std::vector<Vec3> object_normals;              // object-space shading normals, or empty

  Transform to_world_at(float t) const { return transform.empty() ? to_world : transform.at(t); }
  // Object-space vertex v at time t.
  Vec3 object_vertex(uint32_t v, float t) const;
  // The world-space vertices of triangle `tri` (three vertex indices) at time t.
  void triangle(const uint32_t* tri, float t, Vec3 out[3]) const;
};

}  // namespace gp
