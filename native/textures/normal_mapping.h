// Shading normals from textures: tangent-space normal maps (Blender's Normal Map node) and bump
// maps (Blender's Bump node), in the frame of the surface's uv parameterisation, plus the
// correction that keeps a bent normal from reflecting the viewer below the surface. The scene
// applies them at every hit (Scene::intersect), so every method shades with the same normal.
#pragma once

#include "core/math.h"
#include "textures/texture.h"

namespace gp {

// Partial derivatives of position in uv over one triangle (dp/du, dp/dv); false when its uvs
// are degenerate (no tangent frame: normal and bump maps are then skipped).
bool triangle_dpduv(const Vec3& p0, const Vec3& p1, const Vec3& p2, Vec2 uv0, Vec2 uv1, Vec2 uv2, Vec3* dpdu,
                    Vec3* dpdv);

// Normal map: texel c (Non-Color) gives t = 2c - 1 in the frame (T, B, ns), T = dp/du made
// orthogonal to ns, B = ns x T signed along dp/dv (MikkTSpace's convention, per triangle);
// strength s blends n = normalize(ns + s (n_map - ns)) as Cycles' Normal Map node.
Vec3 normal_mapped(const TextureRef& tex, float strength, Vec2 uv, const Vec3& ns, const Vec3& dpdu,
                   const Vec3& dpdv);

// Bump map: the surface displaced by h = distance * height(uv) along ns; its normal by the
// surface gradient (Mikkelsen 2020, "Surface Gradient-Based Bump Mapping Framework", eq. 2-4):
// n' = normalize(ns - grad_s h) with grad_s h = dh/du grad u + dh/dv grad v; strength blends
// as in normal_mapped.
Vec3 bump_mapped(const TextureRef& tex, float strength, float distance, Vec2 uv, const Vec3& ns, const Vec3& dpdu,
                 const Vec3& dpdv);

// A shading normal n (unit) bent toward the geometric normal ng just enough that the mirror
// direction of wo about it stays above the surface (as Cycles' ensure_valid_reflection): a
// normal map can tilt n so far that reflection would go through the surface. wo points away
// from the surface; the result is on the same side of ng as n.
Vec3 valid_reflection_normal(const Vec3& ng, const Vec3& wo, const Vec3& n);

}  // namespace gp
