// A mesh's named attributes as the Color Attribute and Attribute nodes read them: Blender's
// colour attributes (point or corner domain, byte or float: byte colours arrive already
// converted to scene-linear, as Cycles converts them, blender/mesh.cpp) and generic float /
// vector attributes, interpolated over the hit triangle as Cycles' primitive_surface_attribute
// does (kernel/geom/triangle.h: vertex and corner elements by barycentrics, face elements
// constant).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"

namespace gp::shading {

enum class AttributeDomain : uint8_t { Point, Corner, Face };

struct MeshAttribute {
  std::string name;
  AttributeDomain domain = AttributeDomain::Point;
  uint8_t components = 4;     // 1 float, 2 float2 (UV maps), 3 vector / RGB, 4 RGBA colour
  std::vector<float> values;  // components per element: per vertex, 3 per triangle, 1 per triangle
  size_t element_count() const { return components ? values.size() / components : 0; }
};

// One mesh's attributes; `default_color` is the render colour attribute (Blender's camera
// icon): what a Color Attribute node with an empty name reads (Cycles' ATTR_STD_VERTEX_COLOR).
struct MeshAttributes {
  std::vector<MeshAttribute> list;
  int default_color = -1;
  const MeshAttribute* find(const std::string& name) const {
    for (const MeshAttribute& a : list)
      if (a.name == name) return &a;
    return nullptr;
  }
};

// An attribute's value at barycentric (b1, b2) of triangle `prim` (vertex indices `tri`), as
// four floats (missing components 0) and its component count.
struct AttributeValue {
  float v[4] = {0, 0, 0, 0};
  int components = 0;  // 0: not found
};
inline AttributeValue interpolate_attribute(const MeshAttribute& a, int prim, const uint32_t* tri, Vec2 bary) {
  AttributeValue r;
  r.components = a.components;
  const int c = a.components;
  const float b1 = bary.x, b2 = bary.y, b0 = 1.0f - b1 - b2;
  if (a.domain == AttributeDomain::Face) {
    const float* f = &a.values[static_cast<size_t>(prim) * c];
    for (int k = 0; k < c; ++k) r.v[k] = f[k];
    return r;
  }
  size_t e0, e1, e2;
  if (a.domain == AttributeDomain::Corner) {
    e0 = 3 * static_cast<size_t>(prim), e1 = e0 + 1, e2 = e0 + 2;
  } else {
    e0 = tri[0], e1 = tri[1], e2 = tri[2];
  }
  for (int k = 0; k < c; ++k)
    r.v[k] = a.values[e0 * c + k] * b0 + a.values[e1 * c + k] * b1 + a.values[e2 * c + k] * b2;
  return r;
}

}  // namespace gp::shading
