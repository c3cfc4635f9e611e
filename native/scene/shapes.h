// Triangle-mesh generators for the analytic shapes of the scene format (sphere, quad, box,
// torus, disk) and a mesh transform. Every generator returns a closed or open gp::Mesh with
// consistent winding (geometric normal = cross(p1 - p0, p2 - p0) points outward / along the
// stated facing), no degenerate triangles, and every material id set to `material`.
// Invalid parameters (non-positive radius, too few segments, degenerate axes) throw
// std::invalid_argument; the scene loader checks them first and reports the JSON path.
#pragma once

#include <cstdint>

#include "core/math.h"
#include "scene/scene.h"

namespace gp {

// UV sphere with smooth (exact, outward) vertex normals: `segments` >= 3 slices around +Z and
// max(2, segments / 2) stacks. The poles are single vertices closed with triangle fans, so
// there are no zero-area triangles and the mesh is closed (every edge shared by two triangles).
// 2 * segments * (stacks - 1) triangles.
Mesh make_sphere(const Vec3& center, float radius, int segments = 48, uint32_t material = 0);

// Parallelogram centred at `center` with half-edge vectors u and v: corners center -u -v,
// +u -v, +u +v, -u +v. Facing (geometric normal) = normalize(cross(u, v)). Two triangles, UVs
// (0,0)..(1,1) along u and v; flat (no vertex normals).
Mesh make_quad(const Vec3& center, const Vec3& u, const Vec3& v, uint32_t material = 0);
// Quad from four corners in counter-clockwise order seen from the side it faces
// (facing = cross(p1 - p0, p2 - p0)); triangles (p0, p1, p2) and (p0, p2, p3).
Mesh make_quad_corners(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, uint32_t material = 0);

// Axis-aligned box, closed, outward facing, flat: 8 shared vertices, 12 triangles.
// Requires min < max on every axis.
Mesh make_box(const Vec3& min, const Vec3& max, uint32_t material = 0);

// Torus around the +Z axis through `center`: tube of radius minor_radius swept along a circle
// of radius major_radius in the XY plane. Smooth outward normals; closed;
// 2 * segments_major * segments_minor triangles. Requires 0 < minor_radius < major_radius.
Mesh make_torus(const Vec3& center, float major_radius, float minor_radius, int segments_major = 48,
                int segments_minor = 24, uint32_t material = 0);

// Disk in the plane z = center.z facing +Z: a centre vertex and `segments` >= 3 rim vertices,
// `segments` triangles; planar UVs in [0,1]^2; flat.
Mesh make_disk(const Vec3& center, float radius, int segments = 48, uint32_t material = 0);

// Transforms positions (Transform::point) and normals (Transform::normal, renormalised) in
// place. A mirroring transform (negative determinant) also reverses every triangle's winding
// so the geometric normal keeps pointing to the same side of the surface as before.
void apply_transform(Mesh& mesh, const Transform& transform);

// Determinant of the upper-left 3x3 block (the linear part).
float linear_determinant(const Transform& t);

// Sum of the triangle areas.
double surface_area(const Mesh& mesh);

}  // namespace gp
