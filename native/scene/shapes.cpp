#include "scene/shapes.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace gp {

namespace {

void add_triangle(Mesh& m, uint32_t a, uint32_t b, uint32_t c, uint32_t material) {
  m.indices.insert(m.indices.end(), {a, b, c});
  m.material_ids.push_back(material);
}

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(what);
}

}  // namespace

Mesh make_sphere(const Vec3& center, float radius, int segments, uint32_t material) {
  require(radius > 0 && std::isfinite(radius), "make_sphere: radius must be positive and finite");
  require(segments >= 3, "make_sphere: segments must be at least 3");
  const int stacks = std::max(2, segments / 2);
  Mesh m;
  // Vertex 0: north pole; then stacks - 1 rings of `segments` vertices; last: south pole.
  // Each ring vertex is computed once, so shared edges are bit-identical (watertight).
  auto add_vertex = [&](const Vec3& n) {
    m.positions.push_back(center + n * radius);
    m.normals.push_back(n);
  };
  add_vertex({0, 0, 1});
  for (int i = 1; i < stacks; ++i) {
    const double theta = std::numbers::pi * i / stacks;
    const double st = std::sin(theta), ct = std::cos(theta);
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * std::numbers::pi * j / segments;
      add_vertex(Vec3(static_cast<float>(st * std::cos(phi)), static_cast<float>(st * std::sin(phi)),
                      static_cast<float>(ct)));
    }
  }
  add_vertex({0, 0, -1});
  const uint32_t south = static_cast<uint32_t>(m.positions.size() - 1);
  auto ring = [&](int i, int j) { return static_cast<uint32_t>(1 + (i - 1) * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) add_triangle(m, 0, ring(1, j), ring(1, j + 1), material);
  for (int i = 1; i + 1 < stacks; ++i)
    for (int j = 0; j < segments; ++j) {
      // a b (upper ring), c d (lower ring); counter-clockwise seen from outside.
      const uint32_t a = ring(i, j), b = ring(i, j + 1), c = ring(i + 1, j), d = ring(i + 1, j + 1);
      add_triangle(m, a, c, d, material);
      add_triangle(m, a, d, b, material);
    }
  for (int j = 0; j < segments; ++j) add_triangle(m, south, ring(stacks - 1, j + 1), ring(stacks - 1, j), material);
  return m;
}

Mesh make_quad(const Vec3& center, const Vec3& u, const Vec3& v, uint32_t material) {
  require(is_finite(center) && is_finite(u) && is_finite(v), "make_quad: non-finite input");
  require(length_squared(cross(u, v)) > 0, "make_quad: u and v must span a plane (non-zero, not parallel)");
  Mesh m = make_quad_corners(center - u - v, center + u - v, center + u + v, center - u + v, material);
  return m;
}

Mesh make_quad_corners(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, uint32_t material) {
  Mesh m;
  m.positions = {p0, p1, p2, p3};
  m.uvs = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  add_triangle(m, 0, 1, 2, material);
  add_triangle(m, 0, 2, 3, material);
  return m;
}

Mesh make_box(const Vec3& lo, const Vec3& hi, uint32_t material) {
  require(is_finite(lo) && is_finite(hi), "make_box: non-finite corner");
  require(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z, "make_box: min must be below max on every axis");
  Mesh m;
  // Vertex k has x = hi if bit 0, y = hi if bit 1, z = hi if bit 2.
  for (int k = 0; k < 8; ++k)
    m.positions.push_back({(k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z});
  // Each face as four corners counter-clockwise seen from outside.
  const uint32_t faces[6][4] = {
      {0, 2, 3, 1},  // z = lo, facing -Z
      {4, 5, 7, 6},  // z = hi, facing +Z
      {0, 1, 5, 4},  // y = lo, facing -Y
      {2, 6, 7, 3},  // y = hi, facing +Y
      {0, 4, 6, 2},  // x = lo, facing -X
      {1, 3, 7, 5},  // x = hi, facing +X
  };
  for (const auto& f : faces) {
    add_triangle(m, f[0], f[1], f[2], material);
    add_triangle(m, f[0], f[2], f[3], material);
  }
  return m;
}

Mesh make_torus(const Vec3& center, float major_radius, float minor_radius, int segments_major,
                int segments_minor, uint32_t material) {
  require(minor_radius > 0 && std::isfinite(major_radius), "make_torus: minor radius must be positive");
  require(minor_radius < major_radius, "make_torus: minor radius must be below the major radius");
  require(segments_major >= 3 && segments_minor >= 3, "make_torus: segments must be at least 3");
  Mesh m;
  for (int i = 0; i < segments_major; ++i) {
    const double u = 2.0 * std::numbers::pi * i / segments_major;
    const double cu = std::cos(u), su = std::sin(u);
    for (int j = 0; j < segments_minor; ++j) {
      const double v = 2.0 * std::numbers::pi * j / segments_minor;
      const double cv = std::cos(v), sv = std::sin(v);
      const double rr = major_radius + minor_radius * cv;
      m.positions.push_back(center + Vec3(static_cast<float>(rr * cu), static_cast<float>(rr * su),
                                          static_cast<float>(minor_radius * sv)));
      m.normals.push_back(Vec3(static_cast<float>(cv * cu), static_cast<float>(cv * su), static_cast<float>(sv)));
    }
  }
  auto idx = [&](int i, int j) {
    return static_cast<uint32_t>((i % segments_major) * segments_minor + (j % segments_minor));
  };
  for (int i = 0; i < segments_major; ++i)
    for (int j = 0; j < segments_minor; ++j) {
      // Outward: d(position)/du x d(position)/dv points along the normal for increasing i, j.
      const uint32_t a = idx(i, j), b = idx(i + 1, j), c = idx(i + 1, j + 1), d = idx(i, j + 1);
      add_triangle(m, a, b, c, material);
      add_triangle(m, a, c, d, material);
    }
  return m;
}

Mesh make_disk(const Vec3& center, float radius, int segments, uint32_t material) {
  require(radius > 0 && std::isfinite(radius), "make_disk: radius must be positive and finite");
  require(segments >= 3, "make_disk: segments must be at least 3");
  Mesh m;
  m.positions.push_back(center);
  m.uvs.push_back(Vec2(0.5f, 0.5f));
  for (int j = 0; j < segments; ++j) {
    const double phi = 2.0 * std::numbers::pi * j / segments;
    const float x = static_cast<float>(std::cos(phi)), y = static_cast<float>(std::sin(phi));
    m.positions.push_back(center + Vec3(x * radius, y * radius, 0.0f));
    m.uvs.push_back(Vec2(0.5f + 0.5f * x, 0.5f + 0.5f * y));
  }
  for (int j = 0; j < segments; ++j)
    add_triangle(m, 0, static_cast<uint32_t>(1 + j), static_cast<uint32_t>(1 + (j + 1) % segments), material);
  return m;
}

float linear_determinant(const Transform& t) {
  const auto& m = t.m;
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

void apply_transform(Mesh& mesh, const Transform& transform) {
  for (Vec3& p : mesh.positions) p = transform.point(p);
  for (Vec3& n : mesh.normals) {
    const Vec3 t = transform.normal(n);
    const float len = length(t);
    n = len > 0 ? t / len : t;
  }
  if (linear_determinant(transform) < 0)
    for (size_t k = 0; k + 2 < mesh.indices.size(); k += 3) std::swap(mesh.indices[k + 1], mesh.indices[k + 2]);
}

double surface_area(const Mesh& mesh) {
  double area = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3 &a = mesh.positions[mesh.indices[3 * t]], &b = mesh.positions[mesh.indices[3 * t + 1]],
               &c = mesh.positions[mesh.indices[3 * t + 2]];
    area += 0.5 * static_cast<double>(length(cross(b - a, c - a)));
  }
  return area;
}

}  // namespace gp
