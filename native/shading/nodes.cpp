// The node types: sockets with Blender 3.4's identifiers and defaults, and one evaluation per
// node, named after it, carrying Cycles 3.4's formulas (kernel/svm/*.h; file named at each).
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <map>

#include "core/spectrum.h"
#include "lights/environment_map.h"
#include "lights/sky.h"
#include "lights/world_graph.h"
#include "shading/node_types.h"
#include "shading/procedural.h"

namespace gp::shading {

namespace {

constexpr float kPiF = 3.14159265358979323846f;
using F = SocketType;
const Vec3 kZero(0.0f);

// ---- Small maths as Cycles' util (util/math_float3.h, kernel/svm/math_util.h) ----

float safe_divide(float a, float b) { return b != 0.0f ? a / b : 0.0f; }
Vec3 safe_divide(const Vec3& a, const Vec3& b) {
  return {safe_divide(a.x, b.x), safe_divide(a.y, b.y), safe_divide(a.z, b.z)};
}
Vec3 mul(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
Vec3 lerp3(const Vec3& a, const Vec3& b, float t) { return a * (1.0f - t) + b * t; }
Vec3 vmax3(const Vec3& a, float m) { return {std::max(a.x, m), std::max(a.y, m), std::max(a.z, m)}; }
Vec3 saturate3(const Vec3& a) {
  return {std::clamp(a.x, 0.0f, 1.0f), std::clamp(a.y, 0.0f, 1.0f), std::clamp(a.z, 0.0f, 1.0f)};
}
float saturate(float a) { return std::clamp(a, 0.0f, 1.0f); }
Vec3 safe_normalize(const Vec3& a) {
  const float l = std::sqrt(dot(a, a));
  return l != 0.0f ? a / l : a;
}
template <typename Fn>
Vec3 map3(const Vec3& a, Fn f) { return {f(a.x), f(a.y), f(a.z)}; }
float luminance(const Vec3& c) { return as_float(c, Conversion::ColorToFloat); }
// CIE XYZ to linear Rec.709 (D65, no chromatic adaptation): what Cycles' xyz_to_rgb does with
// Blender's colour configuration (Blackbody, Wavelength).
Vec3 xyz_to_rec709(const Vec3& v) {
  return {3.2404542f * v.x - 1.5371385f * v.y - 0.4985314f * v.z, -0.9692660f * v.x + 1.8760108f * v.y + 0.0415560f * v.z,
          0.0556434f * v.x - 0.2040259f * v.y + 1.0572252f * v.z};
}
float fract(float a) { return a - std::floor(a); }
float smoothstep(float e0, float e1, float x) {  // util/math_float.h smoothstep
  if (x < e0) return 0.0f;
  if (x >= e1) return 1.0f;
  const float t = (x - e0) / (e1 - e0);
  return (3.0f - 2.0f * t) * t * t;
}
float smootherstep(float e0, float e1, float x) {
  x = std::clamp(safe_divide(x - e0, e1 - e0), 0.0f, 1.0f);
  return x * x * x * (x * (x * 6.0f - 15.0f) + 10.0f);
}
float wrapf(float v, float max, float min) {
  const float range = max - min;
  return range != 0.0f ? v - range * std::floor((v - min) / range) : min;
}
float pingpongf(float a, float b) { return b != 0.0f ? std::abs(fract((a - b) / (b * 2.0f)) * b * 2.0f - b) : 0.0f; }
float smoothminf(float a, float b, float k) {
  if (k != 0.0f) {
    const float h = std::max(k - std::abs(a - b), 0.0f) / k;
    return std::min(a, b) - h * h * h * k * (1.0f / 6.0f);
  }
  return std::min(a, b);
}
float signf(float a) { return a > 0.0f ? 1.0f : (a < 0.0f ? -1.0f : 0.0f); }

// Rotation of Euler angles XYZ (util/transform.h euler_to_transform): rows of R = Rz Ry Rx.
struct Mat3 {
  Vec3 r[3];
  Vec3 apply(const Vec3& a) const { return {dot(r[0], a), dot(r[1], a), dot(r[2], a)}; }
  Vec3 apply_t(const Vec3& a) const { return r[0] * a.x + r[1] * a.y + r[2] * a.z; }
};
Mat3 euler_to_mat(const Vec3& e) {
  const float cx = std::cos(e.x), cy = std::cos(e.y), cz = std::cos(e.z);
  const float sx = std::sin(e.x), sy = std::sin(e.y), sz = std::sin(e.z);
  Mat3 m;
  m.r[0] = Vec3(cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz);
  m.r[1] = Vec3(cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz);
  m.r[2] = Vec3(-sy, cy * sx, cy * cx);
  return m;
}

// ---- Colour (util/color.h) ----

Vec3 rgb_to_hsv(const Vec3& rgb) {
  const float cmax = std::max(rgb.x, std::max(rgb.y, rgb.z));
  const float cmin = std::min(rgb.x, std::min(rgb.y, rgb.z));
  const float cdelta = cmax - cmin;
  float h = 0.0f, s = 0.0f;
  const float v = cmax;
  if (cmax != 0.0f) s = cdelta / cmax;
  if (s != 0.0f) {
    const Vec3 c = (Vec3(cmax) - rgb) / cdelta;
    if (rgb.x == cmax) h = c.z - c.y;
    else if (rgb.y == cmax) h = 2.0f + c.x - c.z;
    else h = 4.0f + c.y - c.x;
    h /= 6.0f;
    if (h < 0.0f) h += 1.0f;
  }
  return {h, s, v};
}
Vec3 hsv_to_rgb(const Vec3& hsv) {
  float h = hsv.x;
  const float s = hsv.y, v = hsv.z;
  if (s == 0.0f) return Vec3(v);
  if (h == 1.0f) h = 0.0f;
  h *= 6.0f;
  const float i = std::floor(h), f = h - i;
  const float p = v * (1.0f - s), q = v * (1.0f - s * f), t = v * (1.0f - s * (1.0f - f));
  switch (static_cast<int>(i)) {
    case 0: return {v, t, p};
    case 1: return {q, v, p};
    case 2: return {p, v, t};
    case 3: return {p, q, v};
    case 4: return {t, p, v};
    default: return {v, p, q};
  }
}
Vec3 rgb_to_hsl(const Vec3& rgb) {
  const float cmax = std::max(rgb.x, std::max(rgb.y, rgb.z));
  const float cmin = std::min(rgb.x, std::min(rgb.y, rgb.z));
  const float l = std::min(1.0f, (cmax + cmin) / 2.0f);
  if (cmax == cmin) return {0.0f, 0.0f, l};
  const float d = cmax - cmin;
  const float s = l > 0.5f ? d / (2.0f - cmax - cmin) : d / (cmax + cmin);
  float h;
  if (cmax == rgb.x) h = (rgb.y - rgb.z) / d + (rgb.y < rgb.z ? 6.0f : 0.0f);
  else if (cmax == rgb.y) h = (rgb.z - rgb.x) / d + 2.0f;
  else h = (rgb.x - rgb.y) / d + 4.0f;
  return {h / 6.0f, s, l};
}
Vec3 hsl_to_rgb(const Vec3& hsl) {
  const float h = hsl.x, s = hsl.y, l = hsl.z;
  const float nr = std::clamp(std::abs(h * 6.0f - 3.0f) - 1.0f, 0.0f, 1.0f);
  const float ng = std::clamp(2.0f - std::abs(h * 6.0f - 2.0f), 0.0f, 1.0f);
  const float nb = std::clamp(2.0f - std::abs(h * 6.0f - 4.0f), 0.0f, 1.0f);
  const float chroma = (1.0f - std::abs(2.0f * l - 1.0f)) * s;
  return {(nr - 0.5f) * chroma + l, (ng - 0.5f) * chroma + l, (nb - 0.5f) * chroma + l};
}

// ---- Blend modes (kernel/svm/color_util.h svm_mix_*; Blender's blend_type order) ----

enum Blend {
  kMix, kDarken, kMultiply, kBurn, kLighten, kScreen, kDodge, kAdd, kOverlay, kSoftLight, kLinearLight,
  kDifference, kSubtract, kDivide, kHue, kSaturation, kColor, kValue, kExclusion
};
const std::initializer_list<const char*> kBlendNames = {
    "MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD", "OVERLAY", "SOFT_LIGHT",
    "LINEAR_LIGHT", "DIFFERENCE", "SUBTRACT", "DIVIDE", "HUE", "SATURATION", "COLOR", "VALUE", "EXCLUSION"};

Vec3 blend(int mode, float t, const Vec3& c1, const Vec3& c2) {
  const float tm = 1.0f - t;
  const Vec3 one(1.0f);
  switch (mode) {
    case kMix: return lerp3(c1, c2, t);
    case kAdd: return lerp3(c1, c1 + c2, t);
    case kMultiply: return lerp3(c1, mul(c1, c2), t);
    case kScreen: return one - mul(one * tm + (one - c2) * t, one - c1);
    case kOverlay: {
      Vec3 o;
      for (int i = 0; i < 3; ++i)
        o[i] = c1[i] < 0.5f ? c1[i] * (tm + 2.0f * t * c2[i]) : 1.0f - (tm + 2.0f * t * (1.0f - c2[i])) * (1.0f - c1[i]);
      return o;
    }
    case kSubtract: return lerp3(c1, c1 - c2, t);
    case kDivide: {
      Vec3 o = c1;
      for (int i = 0; i < 3; ++i)
        if (c2[i] != 0.0f) o[i] = tm * c1[i] + t * c1[i] / c2[i];
      return o;
    }
    case kDifference: return lerp3(c1, map3(c1 - c2, [](float x) { return std::abs(x); }), t);
    case kExclusion: return vmax3(lerp3(c1, c1 + c2 - mul(c1, c2) * 2.0f, t), 0.0f);
    case kDarken: return lerp3(c1, vmin(c1, c2), t);
    case kLighten: return lerp3(c1, vmax(c1, c2), t);
    case kDodge: {
      Vec3 o = c1;
      for (int i = 0; i < 3; ++i) {
        if (o[i] != 0.0f) {
          const float tmp = 1.0f - t * c2[i];
          if (tmp <= 0.0f) o[i] = 1.0f;
          else o[i] = std::min(o[i] / tmp, 1.0f);
        }
      }
      return o;
    }
    case kBurn: {
      Vec3 o;
      for (int i = 0; i < 3; ++i) {
        float tmp = tm + t * c2[i];
        if (tmp <= 0.0f) o[i] = 0.0f;
        else if ((tmp = 1.0f - (1.0f - c1[i]) / tmp) < 0.0f) o[i] = 0.0f;
        else o[i] = std::min(tmp, 1.0f);
      }
      return o;
    }
    case kHue: {
      Vec3 o = c1;
      const Vec3 hsv2 = rgb_to_hsv(c2);
      if (hsv2.y != 0.0f) {
        Vec3 hsv = rgb_to_hsv(o);
        hsv.x = hsv2.x;
        o = lerp3(o, hsv_to_rgb(hsv), t);
      }
      return o;
    }
    case kSaturation: {
      Vec3 hsv = rgb_to_hsv(c1);
      if (hsv.y != 0.0f) {
        const Vec3 hsv2 = rgb_to_hsv(c2);
        hsv.y = tm * hsv.y + t * hsv2.y;
        return hsv_to_rgb(hsv);
      }
      return c1;
    }
    case kValue: {
      Vec3 hsv = rgb_to_hsv(c1);
      const Vec3 hsv2 = rgb_to_hsv(c2);
      hsv.z = tm * hsv.z + t * hsv2.z;
      return hsv_to_rgb(hsv);
    }
    case kColor: {
      Vec3 o = c1;
      const Vec3 hsv2 = rgb_to_hsv(c2);
      if (hsv2.y != 0.0f) {
        Vec3 hsv = rgb_to_hsv(o);
        hsv.x = hsv2.x;
        hsv.y = hsv2.y;
        o = lerp3(o, hsv_to_rgb(hsv), t);
      }
      return o;
    }
    case kSoftLight: {
      const Vec3 scr = one - mul(one - c2, one - c1);
      return c1 * tm + (mul(mul(one - c1, c2), c1) + mul(c1, scr)) * t;
    }
    case kLinearLight: return c1 + (c2 * 2.0f - one) * t;
  }
  return c1;
}

// ---- Property parsers ----

void parse_math(const PropReader& r, NodeProps& p);
void parse_vector_math(const PropReader& r, NodeProps& p);

// ---- Input nodes ----

Vec3 object_point(const ShadingContext& c, const Vec3& p) { return c.object ? c.object->to_object.point(p) : p; }
Vec3 generated(const ShadingContext& c) {
  if (!c.surface) return c.P;
  const Vec3 o = object_point(c, c.P);
  if (!c.object || c.object->bounds.empty()) return o;
  const Vec3 d = c.object->bounds.diagonal();
  return safe_divide(o - c.object->bounds.lo, d);
}
Vec3 normal_object(const ShadingContext& c) {
  // Normals go to object space by the transpose of the object-to-world matrix's 3x3 part.
  if (!c.object) return c.N;
  const Transform& w = c.object->to_world;
  const Vec3 n(w.m[0][0] * c.N.x + w.m[1][0] * c.N.y + w.m[2][0] * c.N.z,
               w.m[0][1] * c.N.x + w.m[1][1] * c.N.y + w.m[2][1] * c.N.z,
               w.m[0][2] * c.N.x + w.m[1][2] * c.N.y + w.m[2][2] * c.N.z);
  return safe_normalize(n);
}

// The hidden input of an unlinked texture Vector / Normal (Cycles' LINK_TEXTURE_GENERATED etc.).
void eval_implicit(EvalArgs& a) {
  switch (static_cast<Implicit>(a.op.props.mode)) {
    case Implicit::Generated: a.out(0, generated(a.ctx)); break;
    case Implicit::UV: a.out(0, Vec3(a.ctx.uv.x, a.ctx.uv.y, 0.0f)); break;
    case Implicit::Normal: a.out(0, a.ctx.N); break;
    default: a.out(0, a.ctx.P); break;
  }
}

// Texture Coordinate's `object` (exported as that object's matrix_world, `object_matrix`, rows of
// 4 numbers): Object is then the shading point through the inverse of that matrix, translation
// included, on a surface and in the World, where the point is the ray direction (svm/tex_coord.h
// NODE_TEXCO_OBJECT with use_transform: transform_point by the inverse matrix; Blender's
// blender/shader.cpp sets it from the object's matrix_world).
void parse_tex_coord(const PropReader& r, NodeProps& p) {
  const nlohmann::json* m = r.get("object_matrix");
  if (!m) return;
  if (!m->is_array() || (m->size() != 3 && m->size() != 4)) r.fail("object_matrix: expected 3 or 4 rows of 4 numbers");
  Transform t;
  for (size_t i = 0; i < m->size(); ++i) {
    const nlohmann::json& row = (*m)[i];
    if (!row.is_array() || row.size() != 4) r.fail("object_matrix: expected 3 or 4 rows of 4 numbers");
    for (size_t j = 0; j < 4; ++j) {
      if (!row[j].is_number()) r.fail("object_matrix: expected 3 or 4 rows of 4 numbers");
      t.m[i][j] = row[j].get<float>();
      if (!std::isfinite(t.m[i][j])) r.fail("object_matrix: not finite");
    }
  }
  const float det = t.m[0][0] * (t.m[1][1] * t.m[2][2] - t.m[1][2] * t.m[2][1]) -
                    t.m[0][1] * (t.m[1][0] * t.m[2][2] - t.m[1][2] * t.m[2][0]) +
                    t.m[0][2] * (t.m[1][0] * t.m[2][1] - t.m[1][1] * t.m[2][0]);
  auto d = std::make_shared<NodeData>();
  // A singular matrix (a zero scale): Cycles' transform_inverse gives zeros; so does this.
  if (std::abs(det) > 0 && std::isfinite(det)) {
    d->transform = invert_affine(t);
  } else {
    for (auto& row : d->transform.m)
      for (float& v : row) v = 0.0f;
  }
  p.flag = true;
  p.data = d;
}

void eval_tex_coord(EvalArgs& a) {  // svm/tex_coord.h
  const ShadingContext& c = a.ctx;
  if (a.used(0)) a.out(0, generated(c));
  if (a.used(1)) a.out(1, c.surface ? normal_object(c) : c.N);
  if (a.used(2)) a.out(2, Vec3(c.uv.x, c.uv.y, 0.0f));
  if (a.used(3))
    a.out(3, a.op.props.flag ? a.op.props.data->transform.point(c.P) : c.surface ? object_point(c, c.P) : c.P);
  // Camera: the point (the World: its direction) in Cycles' camera space; Window: its place
  // in the frame (svm/tex_coord.h, camera_world_to_ndc).
  if (a.used(4))
    a.out(4, !c.camera ? kZero : c.surface ? c.camera->world_to_camera.point(c.P) : c.camera->world_to_camera.vector(c.P));
  // For the World (svm/tex_coord.h, camera_world_to_ndc): a camera ray of an orthographic
  // camera places its origin (sd->ray_P; every such ray has the view's direction), any other
  // ray its direction taken from the camera (perspective: Cycles adds the camera's position)
  // or, orthographic, as a point as it is.
  if (a.used(5)) {
    const Vec3* origin = c.surface || !c.camera || !c.camera->orthographic ? nullptr : WorldRayOrigin::get();
    a.out(5, !c.camera                             ? kZero
             : origin && (c.ray.flags & kPathCamera) ? c.camera->window(*origin, false)
                                                    : c.camera->window(c.P, !c.surface && !c.camera->orthographic));
  }
  if (a.used(6)) a.out(6, c.surface ? c.N * (2.0f * dot(c.N, c.I)) - c.I : c.I);
}
void eval_uv_map(EvalArgs& a) { a.out(0, Vec3(a.ctx.uv.x, a.ctx.uv.y, 0.0f)); }

void eval_geometry(EvalArgs& a) {  // svm/geometry.h
  const ShadingContext& c = a.ctx;
  a.out(0, c.P);
  a.out(1, c.N);
  if (a.used(2)) {
    // primitive_tangent: the radial tangent about the object's Z axis of Generated coordinates.
    Vec3 t;
    if (c.object) {
      const Vec3 g = generated(c);
      t = safe_normalize(c.object->to_world.vector(Vec3(-(g.y - 0.5f), g.x - 0.5f, 0.0f)));
    } else {
      t = safe_normalize(c.dPdu);
    }
    a.out(2, cross(c.N, safe_normalize(cross(t, c.N))));
  }
  a.out(3, c.Ng);
  a.out(4, c.I);
  a.out(5, Vec3(1.0f - c.bary.x - c.bary.y, c.bary.x, 0.0f));
  a.out(6, c.backfacing ? 1.0f : 0.0f);
  a.out(7, 0.5f);  // Pointiness: needs a per-vertex attribute (not exported)
  a.out(8, 0.0f);  // Random Per Island: likewise
}

void eval_object_info(EvalArgs& a) {
  const ShadingContext& c = a.ctx;
  a.out(0, c.object ? c.object->location() : kZero);
  a.out(1, Vec3(1.0f));  // Object.color (Blender's default white; not exported)
  a.out(2, 1.0f);
  a.out(3, 0.0f);
  a.out(4, 0.0f);
  a.out(5, c.object ? c.object->random : 0.0f);
}

float fresnel_dielectric_cos(float cosi, float eta) {  // kernel/closure/bsdf_util.h
  const float c = std::abs(cosi);
  float g = eta * eta - 1.0f + c * c;
  if (g > 0.0f) {
    g = std::sqrt(g);
    const float A = (g - c) / (g + c);
    const float B = (c * (g + c) - 1.0f) / (c * (g - c) + 1.0f);
    return 0.5f * A * A * (1.0f + B * B);
  }
  return 1.0f;
}
void eval_fresnel(EvalArgs& a) {  // svm/fresnel.h
  const Vec3 N = a.v(1);
  float eta = std::max(a.f(0), 1e-5f);
  eta = a.ctx.backfacing ? 1.0f / eta : eta;
  a.out(0, fresnel_dielectric_cos(dot(a.ctx.I, N), eta));
}
void eval_layer_weight(EvalArgs& a) {  // svm/fresnel.h svm_node_layer_weight
  const Vec3 N = a.v(1);
  float blend = a.f(0);
  if (a.used(0)) {
    float eta = std::max(1.0f - blend, 1e-5f);
    eta = a.ctx.backfacing ? eta : 1.0f / eta;
    a.out(0, fresnel_dielectric_cos(dot(a.ctx.I, N), eta));
  }
  if (a.used(1)) {
    float f = std::abs(dot(a.ctx.I, N));
    if (blend != 0.5f) {
      blend = std::clamp(blend, 0.0f, 1.0f - 1e-5f);
      blend = blend < 0.5f ? 2.0f * blend : 0.5f / (1.0f - blend);
      f = std::pow(f, blend);
    }
    a.out(1, 1.0f - f);
  }
}
void eval_light_path(EvalArgs& a) {  // svm/light_path.h
  const RayState& r = a.ctx.ray;
  for (int i = 0; i < 7; ++i) a.out(i, (r.flags >> i) & 1 ? 1.0f : 0.0f);
  a.out(7, r.length);
  // Cycles: a light's emission evaluated for a light sample (or a shadow ray's shading) is one
  // bounce further than the path's vertex; those contexts carry no path flags here (depth 0
  // is kept: the vertex's depth is not known there).
  a.out(8, static_cast<float>(r.depth));
  a.out(9, static_cast<float>(r.diffuse));
  a.out(10, static_cast<float>(r.glossy));
  a.out(11, static_cast<float>(r.transparent));
  a.out(12, static_cast<float>(r.transmission));
}
void parse_value(const PropReader& r, NodeProps& p);
void eval_value(EvalArgs& a) { a.out(0, a.v(0)); }

// The named mesh attribute at the shading point (components 0: not found). An empty name with
// `render_color` is the mesh's render colour attribute (Cycles' ATTR_STD_VERTEX_COLOR).
AttributeValue attribute_at(const ShadingContext& c, const std::string& name, bool render_color) {
  if (!c.object || !c.object->attributes || c.prim < 0 || !c.surface) return {};
  const MeshAttributes& attrs = *c.object->attributes;
  const MeshAttribute* a = nullptr;
  if (name.empty() && render_color) {
    if (attrs.default_color >= 0) a = &attrs.list[attrs.default_color];
  } else {
    a = attrs.find(name);
  }
  if (!a) return {};
  return interpolate_attribute(*a, c.prim, c.object->indices + 3 * static_cast<size_t>(c.prim), c.bary);
}
void parse_color_attribute(const PropReader& r, NodeProps& p) {
  auto d = std::make_shared<NodeData>();
  d->name = r.string("layer_name", "");
  p.data = d;
}
void eval_color_attribute(EvalArgs& a) {  // svm/vertex_color.h
  const AttributeValue v = attribute_at(a.ctx, a.op.props.data->name, true);
  if (v.components == 0) {  // not found: black, alpha 0
    a.out(0, kZero);
    a.out(1, 0.0f);
    return;
  }
  a.out(0, Vec3(v.v[0], v.v[1], v.v[2]));
  a.out(1, v.components == 4 ? v.v[3] : 1.0f);
}
void parse_attribute(const PropReader& r, NodeProps& p) {
  auto d = std::make_shared<NodeData>();
  d->name = r.string("attribute_name", "");
  p.mode = r.choice("attribute_type", {"GEOMETRY", "OBJECT", "INSTANCER", "VIEW_LAYER"}, 0);
  if (p.mode != 0)
    r.warn(fmt::format("Attribute type '{}' is not supported (reads as a missing attribute)",
                       r.string("attribute_type", "")));
  p.data = d;
}
void eval_attribute(EvalArgs& a) {  // svm/attribute.h svm_node_attr
  AttributeValue v;
  if (a.op.props.mode == 0) v = attribute_at(a.ctx, a.op.props.data->name, false);
  // Cycles: a float reads (f, f, f); a float2 (x, y, 0) with Fac x; wider ones their first
  // three with Fac their average; Alpha is a float4's w, else 1 (a missing one: 0, 0, 1).
  Vec3 col(v.v[0], v.v[1], v.v[2]);
  float fac = (v.v[0] + v.v[1] + v.v[2]) * (1.0f / 3.0f);
  if (v.components == 1) col = Vec3(v.v[0]), fac = v.v[0];
  else if (v.components == 2) fac = v.v[0];
  a.out(0, col);
  a.out(1, col);
  a.out(2, fac);
  a.out(3, v.components == 4 ? v.v[3] : 1.0f);
}

// ---- Textures ----

Vec4 vec4_of(const Vec3& v, float w = 0.0f) {
  Vec4 r;
  r[0] = v.x, r[1] = v.y, r[2] = v.z, r[3] = w;
  return r;
}
// A node's N-dimensional point: 1D reads W, 2D xy, 3D xyz, 4D (xyz, W).
Vec4 point_of(const Vec3& v, float w, int dims) {
  Vec4 r;
  if (dims == 1) r[0] = w;
  else r = vec4_of(v, dims == 4 ? w : 0.0f);
  return r;
}
const std::initializer_list<const char*> kDims = {"1D", "2D", "3D", "4D"};
// Specialised Texture Coordinate (NodeType::specialize): no object, only UV and Object read
// (which, decided at compile time).
template <bool UV, bool Object>
void eval_tex_coord_uv_object(EvalArgs& a) {
  const ShadingContext& c = a.ctx;
  if (UV) a.out(2, Vec3(c.uv.x, c.uv.y, 0.0f));
  if (Object) a.out(3, c.surface ? object_point(c, c.P) : c.P);
}
EvalFn specialize_tex_coord(const NodeProps& p, const InputSource*, const uint32_t* outs) {
  if (p.flag) return nullptr;  // an object's matrix
  for (int j : {0, 1, 4, 5, 6})
    if (outs[j] != kTrashRegister) return nullptr;
  const bool uv = outs[2] != kTrashRegister, object = outs[3] != kTrashRegister;
  if (uv && object) return eval_tex_coord_uv_object<true, true>;
  if (uv) return eval_tex_coord_uv_object<true, false>;
  if (object) return eval_tex_coord_uv_object<false, true>;
  return nullptr;
}
void parse_dims(const PropReader& r, NodeProps& p, const char* key) { p.mode = r.choice(key, kDims, 2) + 1; }

void eval_tex_checker(EvalArgs& a) {  // svm/checker.h
  const float f = checker(a.v(0) * a.f(3));
  a.out(0, f == 1.0f ? a.v(1) : a.v(2));
  a.out(1, f);
}

void parse_noise(const PropReader& r, NodeProps& p) { parse_dims(r, p, "noise_dimensions"); }
void eval_tex_noise(EvalArgs& a) {  // svm/noisetex.h (3.4)
  const float scale = a.f(2);
  const int dims = a.op.props.mode;
  float value;
  Vec3 color;
  const float w = dims == 1 || dims == 4 ? a.f(1) * scale : 0.0f;  // W: 1D and 4D only (point_of)
  noise_texture(point_of(a.v(0) * scale, w, dims), dims, a.f(3), a.f(4), a.f(5), a.used(1), &value, &color);
  a.out(0, value);
  if (a.used(1)) a.out(1, color);
}

// Specialised Noise (NodeType::specialize): 3D, whether Color is read decided at compile time;
// `Plain`: Scale, Detail, Roughness and Distortion need no conversion.
template <bool Plain, bool Color>
void eval_tex_noise3(EvalArgs& a) {
  auto f = [&](int i) { return Plain ? a.x(i) : a.f(i); };
  const float scale = f(2);
  float value;
  Vec3 color;
  noise_texture(point_of(a.v(0) * scale, 0.0f, 3), 3, f(3), f(4), f(5), Color, &value, &color);
  a.out(0, value);
  if (Color) a.out(1, color);
}
EvalFn specialize_noise(const NodeProps& p, const InputSource* in, const uint32_t* outs) {
  if (p.mode != 3) return nullptr;
  bool plain = true;
  for (int i = 2; i < 6; ++i) plain = plain && in[i].conv == Conversion::None;
  const bool color = outs[1] != kTrashRegister;
  if (plain) return color ? eval_tex_noise3<true, true> : eval_tex_noise3<true, false>;
  return color ? eval_tex_noise3<false, true> : eval_tex_noise3<false, false>;
}

void parse_voronoi(const PropReader& r, NodeProps& p) {
  parse_dims(r, p, "voronoi_dimensions");
  p.mode2 = r.choice("feature", {"F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE", "N_SPHERE_RADIUS"}, 0);
  p.mode3 = r.choice("distance", {"EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI"}, 0);
}
// Position and W of a Voronoi result (the point over the scale), where they are read.
void write_voronoi_position(EvalArgs& a, const VoronoiOut& o, int dims, float scale);
void eval_tex_voronoi(EvalArgs& a) {  // svm/voronoi.h svm_node_tex_voronoi
  const int dims = a.op.props.mode;
  const float scale = a.f(2);
  const float smoothness = std::clamp(a.f(3) / 2.0f, 0.0f, 0.5f);
  const float randomness = std::clamp(a.f(5), 0.0f, 1.0f);
  const VoronoiOut o = voronoi(static_cast<VoronoiFeature>(a.op.props.mode2),
                               static_cast<VoronoiMetric>(a.op.props.mode3),
                               point_of(a.v(0) * scale, dims == 1 || dims == 4 ? a.f(1) * scale : 0.0f, dims), dims,
                               smoothness, a.f(4), randomness);
  a.out(0, o.distance);
  a.out(1, o.color);
  if (a.used(2) || a.used(3)) write_voronoi_position(a, o, dims, scale);
  a.out(4, o.radius);
}
void write_voronoi_position(EvalArgs& a, const VoronoiOut& o, int dims, float scale) {
  Vec3 pos;
  float w = 0.0f;
  switch (dims) {
    case 1: w = safe_divide(o.position[0], scale); break;
    case 2: pos = Vec3(safe_divide(o.position[0], scale), safe_divide(o.position[1], scale), 0.0f); break;
    case 3: pos = safe_divide(Vec3(o.position[0], o.position[1], o.position[2]), Vec3(scale)); break;
    default:
      pos = safe_divide(Vec3(o.position[0], o.position[1], o.position[2]), Vec3(scale));
      w = safe_divide(o.position[3], scale);
      break;
  }
  a.out(2, pos);
  a.out(3, w);
}

void parse_musgrave(const PropReader& r, NodeProps& p) {
  parse_dims(r, p, "musgrave_dimensions");
  p.mode2 = r.choice("musgrave_type", {"MULTIFRACTAL", "FBM", "HYBRID_MULTIFRACTAL", "RIDGED_MULTIFRACTAL",
                                       "HETERO_TERRAIN"}, 1);
}
void eval_tex_musgrave(EvalArgs& a) {  // svm/musgrave.h svm_node_tex_musgrave
  const int dims = a.op.props.mode;
  const float scale = a.f(2);
  const float detail = std::clamp(a.f(3), 0.0f, 16.0f);
  const float dimension = std::max(a.f(4), 1e-5f);
  const float lacunarity = std::max(a.f(5), 1e-5f);
  a.out(0, musgrave(static_cast<MusgraveType>(a.op.props.mode2), point_of(a.v(0) * scale, a.f(1) * scale, dims),
                    dims, dimension, lacunarity, detail, a.f(6), a.f(7)));
}

void parse_wave(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("wave_type", {"BANDS", "RINGS"}, 0);
  p.mode2 = r.choice("bands_direction", {"X", "Y", "Z", "DIAGONAL"}, 0);
  p.mode3 = r.choice("rings_direction", {"X", "Y", "Z", "SPHERICAL"}, 0);
  p.mode4 = r.choice("wave_profile", {"SIN", "SAW", "TRI"}, 0);
}
void eval_tex_wave(EvalArgs& a) {  // svm/wave.h
  const NodeProps& p = a.op.props;
  const auto rings = p.mode3 == 3 ? WaveDirection::Spherical : static_cast<WaveDirection>(p.mode3);
  const float f = wave(static_cast<WaveType>(p.mode), static_cast<WaveDirection>(p.mode2), rings,
                       static_cast<WaveProfile>(p.mode4), a.v(0) * a.f(1), a.f(2), a.f(3), a.f(4), a.f(5), a.f(6));
  a.out(0, Vec3(f));
  a.out(1, f);
}

void parse_gradient(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("gradient_type", {"LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "RADIAL", "QUADRATIC_SPHERE",
                                      "SPHERICAL"}, 0);
}
void eval_tex_gradient(EvalArgs& a) {  // svm/gradient.h
  const float f = saturate(gradient(static_cast<GradientType>(a.op.props.mode), a.v(0)));
  a.out(0, Vec3(f));
  a.out(1, f);
}

void parse_magic(const PropReader& r, NodeProps& p) { p.mode = r.integer("turbulence_depth", 2, 0, 10); }
void eval_tex_magic(EvalArgs& a) {  // svm/magic.h (3.4)
  const Vec3 c = magic(a.v(0) * a.f(1), a.op.props.mode, a.f(2));
  a.out(0, c);
  a.out(1, (c.x + c.y + c.z) / 3.0f);
}

struct BrickData : NodeData {};
void parse_brick(const PropReader& r, NodeProps& p) {
  p.mode = r.integer("offset_frequency", 2, 1, 99);
  p.mode2 = r.integer("squash_frequency", 2, 1, 99);
  auto d = std::make_shared<NodeData>();
  d->blend = r.number("offset", 0.5f);
  d->alpha = {r.number("squash", 1.0f)};
  p.data = d;
}
void eval_tex_brick(EvalArgs& a) {  // svm/brick.h
  const NodeData& d = *a.op.props.data;
  float tint, mortar;
  brick(a.v(0) * a.f(4), a.f(5), a.f(6), a.f(7), a.f(8), a.f(9), d.blend, a.op.props.mode, d.alpha[0],
        a.op.props.mode2, &tint, &mortar);
  Vec3 c1 = a.v(1);
  if (mortar != 1.0f) c1 = c1 * (1.0f - tint) + a.v(2) * tint;
  a.out(0, c1 * (1.0f - mortar) + a.v(3) * mortar);
  a.out(1, mortar);
}

void parse_white_noise(const PropReader& r, NodeProps& p) { parse_dims(r, p, "noise_dimensions"); }
// ---- The World's textures (lights/world_graph.h evaluates the World's graph) ----

// Environment Texture (svm/image.h, svm_node_tex_environment): the vector normalised, projected
// as Cycles (environment_map.h), looked up with the image's filter and Repeat, as EnvironmentMap.
void parse_tex_environment(const PropReader& r, NodeProps& p) {
  auto d = std::make_shared<NodeData>();
  const std::string path = r.string("image", "");
  if (path.empty()) {
    r.warn("no image: magenta, as Cycles renders a missing image");
  } else if (r.images() && *r.images()) {
    std::string warning;
    d->image = (*r.images())(path, r.string("colorspace", ""), &warning);
    if (!warning.empty()) r.warn(warning);
  }
  p.mode = r.choice("interpolation", {"Linear", "Closest", "Cubic", "Smart"}, 0);
  p.mode2 = r.choice("projection", {"EQUIRECTANGULAR", "MIRROR_BALL"}, 0);
  p.data = d;
}
void eval_tex_environment(EvalArgs& a) {
  const NodeData& d = *a.op.props.data;
  if (!d.image || d.image->missing) {
    a.out(0, Vec3(1, 0, 1));  // Cycles' missing-image magenta
    a.out(1, 1.0f);
    return;
  }
  const Vec3 v = a.v(0);
  const float len = length(v);
  const Vec3 m = len > 0 && std::isfinite(len) ? v / len : Vec3(0.0f);
  const Vec2 uv = a.op.props.mode2 == 0 ? EnvironmentMap::equirectangular_uv(m) : EnvironmentMap::mirror_ball_uv(m);
  static constexpr TextureFilter kFilter[] = {TextureFilter::Linear, TextureFilter::Closest, TextureFilter::Cubic,
                                              TextureFilter::Cubic};  // Smart: Cubic, as Cycles' CPU kernel
  const RGBA t = d.image->lookup(uv, TextureWrap::Repeat, kFilter[a.op.props.mode]);
  a.out(0, Vec3(t.rgb.r, t.rgb.g, t.rgb.b));
  a.out(1, t.a);
}

// Sky Texture (svm/sky.h): the sky of lights/sky.h (precomputed once, shared) along the
// normalised vector (the model reads its spherical angles). Blender's properties in radians.
void parse_tex_sky(const PropReader& r, NodeProps& p) {
  SkyOptions o;
  const int type = r.choice("sky_type", {"PREETHAM", "HOSEK_WILKIE", "NISHITA"}, 2);
  o.model = type == 2 ? SkyModel::Nishita : SkyModel::Preetham;
  if (type == 1) r.warn("Hosek-Wilkie sky rendered as Preetham (its fitted tables are not available)");
  o.sun_disc = r.boolean("sun_disc", true);
  o.sun_size = std::max(0.0f, r.number("sun_size", o.sun_size));
  o.sun_intensity = std::max(0.0f, r.number("sun_intensity", o.sun_intensity));
  o.sun_elevation = r.number("sun_elevation", o.sun_elevation);
  o.sun_rotation = r.number("sun_rotation", o.sun_rotation);
  o.altitude = std::max(0.0f, r.number("altitude", o.altitude));
  o.air_density = std::max(0.0f, r.number("air_density", o.air_density));
  o.dust_density = std::max(0.0f, r.number("dust_density", o.dust_density));
  o.ozone_density = std::max(0.0f, r.number("ozone_density", o.ozone_density));
  o.turbidity = std::max(0.0f, r.number("turbidity", o.turbidity));
  if (const nlohmann::json* j = r.get("sun_direction")) {
    if (!j->is_array() || j->size() != 3 || !(*j)[0].is_number() || !(*j)[1].is_number() || !(*j)[2].is_number())
      r.fail("sun_direction: expected [x, y, z]");
    o.sun_direction = Vec3((*j)[0].get<float>(), (*j)[1].get<float>(), (*j)[2].get<float>());
  }
  auto d = std::make_shared<NodeData>();
  try {
    d->sky = shared_sky(o);
  } catch (const std::invalid_argument& e) {
    r.fail(e.what());
  }
  p.data = d;
}
void eval_tex_sky(EvalArgs& a) {
  const Vec3 v = a.v(0);
  const float len = length(v);
  if (!(len > 0) || !std::isfinite(len)) {
    a.out(0, kZero);
    return;
  }
  // (Without its disc while a World graph bakes the grid its sun's cone complements.)
  const RGB c = a.op.props.data->sky->radiance(v / len, !SkySunDiscsOff::active());
  a.out(0, Vec3(c.r, c.g, c.b));
}

void eval_tex_white_noise(EvalArgs& a) {  // svm/white_noise.h
  float value;
  Vec3 color;
  white_noise(point_of(a.v(0), a.f(1), a.op.props.mode), a.op.props.mode, &value, &color);
  a.out(0, value);
  a.out(1, color);
}

// ---- Image texture (svm/image.h) ----

enum ImageExtension { kRepeat, kExtend, kClip, kMirror };
enum ImageInterp { kLinear, kClosest, kCubic, kSmart };
enum ImageProjection { kFlat, kBox, kSphere, kTube };
enum AlphaMode { kStraight, kPremul, kChannelPacked, kAlphaNone };

void parse_image(const PropReader& r, NodeProps& p) {
  auto d = std::make_shared<NodeData>();
  const std::string path = r.string("image", "");
  const std::string colorspace = r.string("colorspace", "");
  if (path.empty()) {
    r.warn("no image: magenta, as Cycles renders a missing image");
  } else if (r.images() && *r.images()) {
    std::string warning;
    d->image = (*r.images())(path, colorspace, &warning);
    if (!warning.empty()) r.warn(warning);
  }
  p.mode = r.choice("interpolation", {"Linear", "Closest", "Cubic", "Smart"}, 0);
  p.mode2 = r.choice("extension", {"REPEAT", "EXTEND", "CLIP", "MIRROR"}, 0);
  p.mode3 = r.choice("projection", {"FLAT", "BOX", "SPHERE", "TUBE"}, 0);
  p.mode4 = r.choice("alpha_mode", {"STRAIGHT", "PREMUL", "CHANNEL_PACKED", "NONE"}, 0);
  d->blend = r.number("projection_blend", 0.0f);
  // Data images (Non-Color, Raw) are never associated with their alpha (Cycles' ImageManager).
  p.flag = colorspace == "Non-Color" || colorspace == "Raw" || colorspace == "Linear Raw";
  p.data = d;
}

int wrap_texel(int i, int n, int ext) {
  switch (ext) {
    case kRepeat: {
      const int m = i % n;
      return m < 0 ? m + n : m;
    }
    case kExtend: return std::clamp(i, 0, n - 1);
    case kClip: return (i < 0 || i >= n) ? -1 : i;
    default: {  // mirror: ... 2 1 0 | 0 1 2 ... n-1 | n-1 n-2 ...
      const int period = 2 * n;
      int m = i % period;
      if (m < 0) m += period;
      return m < n ? m : period - 1 - m;
    }
  }
}
RGBA fetch(const TextureImage& img, int x, int y, int ext) {
  const int xi = wrap_texel(x, img.width, ext), yi = wrap_texel(y, img.height, ext);
  if (xi < 0 || yi < 0) return {RGB(0.0f), 0.0f};
  return img.texel(xi, yi);
}
float texel_coord(float u, int n) {
  if (!std::isfinite(u)) return 0.0f;
  return std::clamp(u, -1e6f, 1e6f) * static_cast<float>(n);
}
// Cubic B-spline weights (Cycles' kernel/device/cpu/image.h, bicubic interpolation).
void bspline_weights(float t, float w[4]) {
  const float t2 = t * t, t3 = t2 * t;
  w[0] = (1.0f / 6.0f) * (-t3 + 3.0f * t2 - 3.0f * t + 1.0f);
  w[1] = (1.0f / 6.0f) * (3.0f * t3 - 6.0f * t2 + 4.0f);
  w[2] = (1.0f / 6.0f) * (-3.0f * t3 + 3.0f * t2 + 3.0f * t + 1.0f);
  w[3] = (1.0f / 6.0f) * t3;
}
RGBA image_lookup(const TextureImage& img, float u, float v, int interp, int ext) {
  if (img.width <= 0 || img.height <= 0) return {RGB(1, 0, 1), 1.0f};
  const float x = texel_coord(u, img.width), y = texel_coord(v, img.height);
  if (interp == kClosest)
    return img.decoded(fetch(img, static_cast<int>(std::floor(x)), static_cast<int>(std::floor(y)), ext));
  const float fx = x - 0.5f, fy = y - 0.5f;
  const float x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = fx - x0f, ty = fy - y0f;
  const int x0 = static_cast<int>(x0f), y0 = static_cast<int>(y0f);
  RGB c(0.0f);
  float alpha = 0.0f;
  if (interp == kLinear) {
    const float w[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
    for (int k = 0; k < 4; ++k) {
      const RGBA t = fetch(img, x0 + (k & 1), y0 + (k >> 1), ext);
      c += t.rgb * w[k];
      alpha += t.a * w[k];
    }
  } else {
    float wx[4], wy[4];
    bspline_weights(tx, wx);
    bspline_weights(ty, wy);
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const RGBA t = fetch(img, x0 - 1 + i, y0 - 1 + j, ext);
        c += t.rgb * (wx[i] * wy[j]);
        alpha += t.a * (wx[i] * wy[j]);
      }
  }
  return img.decoded({c, alpha});
}
Vec2 map_to_sphere(const Vec3& co) {  // util/math.h map_to_sphere
  const float len = std::sqrt(dot(co, co));
  if (len > 0.0f) {
    const float u = (co.x == 0.0f && co.y == 0.0f) ? 0.0f : (1.0f - std::atan2(co.x, co.y) / kPiF) / 2.0f;
    const float v = 1.0f - std::acos(std::clamp(co.z / len, -1.0f, 1.0f)) / kPiF;
    return {u, v};
  }
  return {0.0f, 0.0f};
}
Vec2 map_to_tube(const Vec3& co) {  // util/math.h map_to_tube
  const float len = std::sqrt(co.x * co.x + co.y * co.y);
  if (len > 0.0f) return {(1.0f - std::atan2(co.x / len, co.y / len) / kPiF) / 2.0f, (co.z + 1.0f) / 2.0f};
  return {0.0f, 0.0f};
}
void eval_tex_image(EvalArgs& a) {
  const NodeProps& p = a.op.props;
  const NodeData& d = *p.data;
  if (!d.image) {
    a.out(0, Vec3(1, 0, 1));  // Cycles' missing-image magenta
    a.out(1, 1.0f);
    return;
  }
  const TextureImage& img = *d.image;
  Vec3 co = a.v(0);
  RGBA t;
  auto look = [&](Vec2 uv) { return image_lookup(img, uv.x, uv.y, p.mode, p.mode2); };
  switch (p.mode3) {
    case kSphere: t = look(map_to_sphere((co - Vec3(0.5f)) * 2.0f)); break;
    case kTube: t = look(map_to_tube((co - Vec3(0.5f)) * 2.0f)); break;
    case kBox: {
      // svm_image_texture_box (svm/image.h): up to three planar lookups blended by the
      // object-space normal, projection_blend widening the seams.
      const Vec3 signed_N = normal_object(a.ctx);
      Vec3 N(std::abs(signed_N.x), std::abs(signed_N.y), std::abs(signed_N.z));
      const float sum = N.x + N.y + N.z;
      if (sum > 0.0f) N = N / sum;
      const float blend_ = d.blend;
      const float limit = 0.5f * (1.0f + blend_);
      Vec3 w(0.0f);
      if (N.x > limit * (N.x + N.y) && N.x > limit * (N.x + N.z)) w.x = 1.0f;
      else if (N.y > limit * (N.x + N.y) && N.y > limit * (N.y + N.z)) w.y = 1.0f;
      else if (N.z > limit * (N.x + N.z) && N.z > limit * (N.y + N.z)) w.z = 1.0f;
      else if (blend_ > 0.0f) {
        if (N.z < (1.0f - limit) * (N.y + N.x)) {
          w.x = saturate((N.x / (N.x + N.y) - 0.5f * (1.0f - blend_)) / blend_);
          w.y = 1.0f - w.x;
        } else if (N.x < (1.0f - limit) * (N.y + N.z)) {
          w.y = saturate((N.y / (N.y + N.z) - 0.5f * (1.0f - blend_)) / blend_);
          w.z = 1.0f - w.y;
        } else if (N.y < (1.0f - limit) * (N.x + N.z)) {
          w.x = saturate((N.x / (N.x + N.z) - 0.5f * (1.0f - blend_)) / blend_);
          w.z = 1.0f - w.x;
        } else {
          w = saturate3((N * (2.0f - limit) + Vec3(limit - 1.0f)) / (2.0f * limit - 1.0f));
        }
      } else {
        w.z = 1.0f;
      }
      t = {RGB(0.0f), 0.0f};
      auto add = [&](float wt, Vec2 uv) {
        if (wt <= 0.0f) return;
        const RGBA s = look(uv);
        t.rgb += s.rgb * wt;
        t.a += s.a * wt;
      };
      add(w.x, {signed_N.x < 0.0f ? 1.0f - co.y : co.y, co.z});
      add(w.y, {signed_N.y > 0.0f ? 1.0f - co.x : co.x, co.z});
      add(w.z, {signed_N.z > 0.0f ? 1.0f - co.y : co.y, co.x});
      break;
    }
    default: t = look({co.x, co.y}); break;
  }
  // Cycles keeps images with associated (premultiplied) alpha and unassociates only for a
  // linked Alpha output: Color is premultiplied where Alpha is not used.
  Vec3 c(t.rgb.r, t.rgb.g, t.rgb.b);
  float alpha = t.a;
  const bool data = p.flag;
  if (p.mode4 == kAlphaNone) alpha = 1.0f;
  else if (!data && p.mode4 != kChannelPacked) {
    const bool alpha_used = a.used(1);
    if (p.mode4 == kStraight && !alpha_used) c = c * alpha;
    if (p.mode4 == kPremul && alpha_used && alpha != 0.0f && alpha != 1.0f) c = c / alpha;
  }
  a.out(0, c);
  a.out(1, alpha);
}

// ---- Colour nodes ----

void parse_mix_rgb(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("blend_type", kBlendNames, 0);
  p.flag = r.boolean("use_clamp", false);
}
void eval_mix_rgb(EvalArgs& a) {  // svm/mix.h (the old node: factor clamped)
  Vec3 c = blend(a.op.props.mode, saturate(a.f(0)), a.v(1), a.v(2));
  if (a.op.props.flag) c = saturate3(c);
  a.out(0, c);
}

void parse_mix(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("data_type", {"FLOAT", "VECTOR", "RGBA"}, 0);
  p.mode2 = r.choice("blend_type", kBlendNames, 0);
  p.mode3 = r.choice("factor_mode", {"UNIFORM", "NON_UNIFORM"}, 0);
  p.flag = r.boolean("clamp_factor", true);
  p.flag2 = r.boolean("clamp_result", false);
}
// Mix (3.4): inputs Factor_Float, Factor_Vector, A_Float, B_Float, A_Vector, B_Vector,
// A_Color, B_Color; svm/mix.h svm_node_mix_float / _vector / _vector_non_uniform / _color.
void eval_mix(EvalArgs& a) {
  const NodeProps& p = a.op.props;
  switch (p.mode) {
    case 0: {
      float t = a.f(0);
      if (p.flag) t = saturate(t);
      a.out(0, a.f(2) * (1.0f - t) + a.f(3) * t);
      return;
    }
    case 1: {
      const Vec3 A = a.v(4), B = a.v(5);
      if (p.mode3 == 1) {
        Vec3 t = a.v(1);
        if (p.flag) t = saturate3(t);
        a.out(1, A + mul(t, B - A));
      } else {
        float t = a.f(0);
        if (p.flag) t = saturate(t);
        a.out(1, A + (B - A) * t);
      }
      return;
    }
    default: {
      float t = a.f(0);
      if (p.flag) t = saturate(t);
      Vec3 c = blend(p.mode2, t, a.v(6), a.v(7));
      if (p.flag2) c = saturate3(c);
      a.out(2, c);
      return;
    }
  }
}

// Specialised Mix (NodeType::specialize): a colour mix whose blend is a lerp to a second colour
// (Mix, Add, Multiply, Subtract), blend()'s expressions with the switches decided at compile
// time; `Plain`: the factor needs no conversion.
template <int Mode, bool ClampFactor, bool ClampResult, bool Plain>
void eval_mix_color_lerp(EvalArgs& a) {
  float t = Plain ? a.x(0) : a.f(0);
  if (ClampFactor) t = saturate(t);
  const Vec3 c1 = a.v(6), c2 = a.v(7);
  const Vec3 to = Mode == kMix ? c2 : Mode == kAdd ? c1 + c2 : Mode == kMultiply ? mul(c1, c2) : c1 - c2;
  Vec3 c = lerp3(c1, to, t);
  if (ClampResult) c = saturate3(c);
  a.out(2, c);
}
template <int Mode, bool CF, bool CR>
EvalFn pick_mix_plain(bool plain) {
  return plain ? eval_mix_color_lerp<Mode, CF, CR, true> : eval_mix_color_lerp<Mode, CF, CR, false>;
}
template <int Mode, bool CF>
EvalFn pick_mix_clamp_result(bool cr, bool plain) {
  return cr ? pick_mix_plain<Mode, CF, true>(plain) : pick_mix_plain<Mode, CF, false>(plain);
}
template <int Mode>
EvalFn pick_mix(const NodeProps& p, bool plain) {
  return p.flag ? pick_mix_clamp_result<Mode, true>(p.flag2, plain) : pick_mix_clamp_result<Mode, false>(p.flag2, plain);
}
EvalFn specialize_mix(const NodeProps& p, const InputSource* in, const uint32_t*) {
  if (p.mode != 2) return nullptr;  // colour only
  const bool plain = in[0].conv == Conversion::None;
  switch (p.mode2) {
    case kMix: return pick_mix<kMix>(p, plain);
    case kAdd: return pick_mix<kAdd>(p, plain);
    case kMultiply: return pick_mix<kMultiply>(p, plain);
    case kSubtract: return pick_mix<kSubtract>(p, plain);
    default: return nullptr;
  }
}

// Color Ramp: Blender's BKE_colorband_evaluate sampled into Cycles' 256-entry table
// (blender/shader.cpp, RAMP_TABLE_SIZE), read as kernel/svm/ramp.h rgb_ramp_lookup.
constexpr int kRampTableSize = 256;
struct RampStop {
  float pos;
  float c[4];
};
void key_curve_position_weights(float t, float data[4], bool cardinal) {  // BKE key.c
  const float t2 = t * t, t3 = t2 * t;
  if (cardinal) {
    const float fc = 0.71f;
    data[0] = -fc * t3 + 2.0f * fc * t2 - fc * t;
    data[1] = (2.0f - fc) * t3 + (fc - 3.0f) * t2 + 1.0f;
    data[2] = (fc - 2.0f) * t3 + (3.0f - 2.0f * fc) * t2 + fc * t;
    data[3] = fc * t3 - fc * t2;
  } else {
    const float fc = 1.0f / 6.0f;
    data[0] = -fc * t3 + 0.5f * t2 - 0.5f * t + fc;
    data[1] = 0.5f * t3 - t2 + 0.66666666f;
    data[2] = -0.5f * t3 + 0.5f * t2 + 0.5f * t + fc;
    data[3] = fc * t3;
  }
}
enum RampInterp { kRampEase, kRampCardinal, kRampLinear, kRampBSpline, kRampConstant };
// colorband_hue_interp (BKE colorband.c): hue blend by NEAR / FAR / CW / CCW.
float hue_interp(int ipotype_hue, float mfac, float fac, float h1, float h2) {
  float h_interp;
  int mode = 0;  // 0: plain, 1: wrap +1 to the smaller, 2: wrap to the larger
  switch (ipotype_hue) {
    case 0:  // NEAR
      if (h1 < h2 && h2 - h1 > 0.5f) mode = 1;
      else if (h1 > h2 && h2 - h1 < -0.5f) mode = 2;
      break;
    case 1:  // FAR
      if (h1 == h2) mode = 1;  // a full turn, as Blender does
      else if (h1 < h2 && h2 - h1 < 0.5f) mode = 1;
      else if (h1 > h2 && h2 - h1 > -0.5f) mode = 2;
      break;
    case 2:  // CCW
      if (h1 > h2) mode = 2;
      break;
    default:  // CW
      if (h1 < h2) mode = 1;
      break;
  }
  switch (mode) {
    case 1: h_interp = (mfac * (h1 + 1.0f) + fac * h2); break;
    case 2: h_interp = (mfac * h1 + fac * (h2 + 1.0f)); break;
    default: h_interp = mfac * h1 + fac * h2; break;
  }
  return h_interp - std::floor(h_interp);
}
void colorband_evaluate(const std::vector<RampStop>& stops, int ipotype, int color_mode, int hue_mode, float in,
                        float out[4]) {
  const int tot = static_cast<int>(stops.size());
  if (color_mode != 0) ipotype = kRampLinear;  // HSV/HSL blend linearly
  auto copy = [&](const RampStop& s) { std::copy(s.c, s.c + 4, out); };
  if (tot == 1) return copy(stops[0]);
  const bool early = ipotype == kRampLinear || ipotype == kRampEase || ipotype == kRampConstant;
  if (in <= stops[0].pos && early) return copy(stops[0]);
  int a = 0;
  while (a < tot && !(stops[a].pos > in)) ++a;
  RampStop left, right;
  const RampStop *cbd1, *cbd2;  // cbd1: first stop past `in`, cbd2: the one before
  if (a == tot) {
    right = stops[tot - 1];
    right.pos = 1.0f;
    cbd1 = &right;
    cbd2 = &stops[tot - 1];
  } else if (a == 0) {
    left = stops[0];
    left.pos = 0.0f;
    cbd1 = &stops[0];
    cbd2 = &left;
  } else {
    cbd1 = &stops[a];
    cbd2 = &stops[a - 1];
  }
  if (a == tot && early) return copy(*cbd2);
  if (ipotype == kRampConstant) return copy(*cbd2);
  float fac = cbd2->pos != cbd1->pos ? (in - cbd1->pos) / (cbd2->pos - cbd1->pos) : (a != tot ? 0.0f : 1.0f);
  if (ipotype == kRampBSpline || ipotype == kRampCardinal) {
    const RampStop* cbd0 = a >= tot - 1 ? cbd1 : &stops[a + 1];
    const RampStop* cbd3 = a < 2 ? cbd2 : &stops[a - 2];
    fac = saturate(fac);
    float t[4];
    key_curve_position_weights(fac, t, ipotype == kRampCardinal);
    for (int i = 0; i < 4; ++i)
      out[i] = std::clamp(t[3] * cbd3->c[i] + t[2] * cbd2->c[i] + t[1] * cbd1->c[i] + t[0] * cbd0->c[i], 0.0f, 1.0f);
    return;
  }
  if (ipotype == kRampEase) {
    const float fac2 = fac * fac;
    fac = 3.0f * fac2 - 2.0f * fac2 * fac;
  }
  const float mfac = 1.0f - fac;
  if (color_mode == 0) {
    for (int i = 0; i < 4; ++i) out[i] = mfac * cbd1->c[i] + fac * cbd2->c[i];
    return;
  }
  const Vec3 c1(cbd1->c[0], cbd1->c[1], cbd1->c[2]), c2(cbd2->c[0], cbd2->c[1], cbd2->c[2]);
  const bool hsv = color_mode == 1;
  const Vec3 h1 = hsv ? rgb_to_hsv(c1) : rgb_to_hsl(c1), h2 = hsv ? rgb_to_hsv(c2) : rgb_to_hsl(c2);
  const Vec3 h(hue_interp(hue_mode, mfac, fac, h1.x, h2.x), mfac * h1.y + fac * h2.y, mfac * h1.z + fac * h2.z);
  const Vec3 rgb = hsv ? hsv_to_rgb(h) : hsl_to_rgb(h);
  out[0] = rgb.x, out[1] = rgb.y, out[2] = rgb.z;
  out[3] = mfac * cbd1->c[3] + fac * cbd2->c[3];
}
void parse_color_ramp(const PropReader& r, NodeProps& p) {
  const nlohmann::json* ramp = r.get("color_ramp");
  std::vector<RampStop> stops;
  int ipotype = kRampLinear, color_mode = 0, hue_mode = 0;
  if (ramp) {
    if (!ramp->is_object()) r.fail("'color_ramp' must be an object");
    const PropReader rr(ramp, r.where() + " color_ramp", nullptr, nullptr);
    ipotype = rr.choice("interpolation", {"EASE", "CARDINAL", "LINEAR", "B_SPLINE", "CONSTANT"}, kRampLinear);
    color_mode = rr.choice("color_mode", {"RGB", "HSV", "HSL"}, 0);
    hue_mode = rr.choice("hue_interpolation", {"NEAR", "FAR", "CCW", "CW"}, 0);
    const nlohmann::json* el = rr.get("elements");
    if (el) {
      if (!el->is_array() || el->empty() || el->size() > 32)
        r.fail("color_ramp 'elements' must be an array of 1 to 32 stops");
      for (const auto& e : *el) {
        if (!e.is_object() || !e.contains("position") || !e.contains("color") || !e["position"].is_number() ||
            !e["color"].is_array() || e["color"].size() < 3 || e["color"].size() > 4)
          r.fail("a color_ramp element must be {\"position\": number, \"color\": [r, g, b, a]}");
        RampStop s{};
        s.pos = e["position"].get<float>();
        s.c[3] = 1.0f;
        for (size_t i = 0; i < e["color"].size(); ++i) {
          if (!e["color"][i].is_number()) r.fail("a color_ramp colour must hold numbers");
          s.c[i] = e["color"][i].get<float>();
        }
        if (!std::isfinite(s.pos)) r.fail("a color_ramp position must be finite");
        stops.push_back(s);
      }
    }
  }
  if (stops.empty()) stops = {{0.0f, {0, 0, 0, 1}}, {1.0f, {1, 1, 1, 1}}};  // Blender's default ramp
  std::stable_sort(stops.begin(), stops.end(), [](const RampStop& x, const RampStop& y) { return x.pos < y.pos; });
  auto d = std::make_shared<NodeData>();
  d->table.resize(kRampTableSize);
  d->alpha.resize(kRampTableSize);
  for (int i = 0; i < kRampTableSize; ++i) {
    float c[4] = {0, 0, 0, 1};
    colorband_evaluate(stops, ipotype, color_mode, hue_mode, static_cast<float>(i) / (kRampTableSize - 1), c);
    d->table[i] = Vec3(c[0], c[1], c[2]);
    d->alpha[i] = c[3];
  }
  p.flag = ipotype != kRampConstant;  // Cycles interpolates the table unless Constant
  p.data = d;
}
void eval_color_ramp(EvalArgs& a) {  // svm/ramp.h svm_node_rgb_ramp
  const NodeData& d = *a.op.props.data;
  float f = a.f(0);
  if (!std::isfinite(f)) f = 0.0f;
  f = saturate(f) * (kRampTableSize - 1);
  const int i = std::clamp(static_cast<int>(f), 0, kRampTableSize - 1);
  const float t = f - static_cast<float>(i);
  Vec3 c = d.table[i];
  float alpha = d.alpha[i];
  if (a.op.props.flag && t > 0.0f) {
    c = c * (1.0f - t) + d.table[i + 1] * t;
    alpha = alpha * (1.0f - t) + d.alpha[i + 1] * t;
  }
  a.out(0, c);
  a.out(1, alpha);
}

void parse_curves(const PropReader& r, NodeProps& p, size_t expected) {
  auto d = std::make_shared<NodeData>();
  if (const nlohmann::json* m = r.get("mapping")) {
    if (!m->is_object()) r.fail("'mapping' must be an object");
    const PropReader mr(m, r.where() + " mapping", nullptr, nullptr);
    d->extrapolate = mr.choice("extend", {"EXTENDED", "EXTRAPOLATED"}, 1) == 1;
    const nlohmann::json* cs = mr.get("curves");
    if (cs) {
      if (!cs->is_array() || cs->size() != expected)
        r.fail(fmt::format("'mapping' needs {} curves (got {})", expected, cs->is_array() ? cs->size() : 0));
      for (const auto& c : *cs) {
        if (!c.is_array() || c.empty() || c.size() > 4096) r.fail("a curve must be an array of 1 to 4096 [x, y] points");
        Curve curve;
        for (const auto& pt : c) {
          if (!pt.is_array() || pt.size() != 2 || !pt[0].is_number() || !pt[1].is_number())
            r.fail("a curve point must be [x, y]");
          const Vec2 v(pt[0].get<float>(), pt[1].get<float>());
          if (!std::isfinite(v.x) || !std::isfinite(v.y)) r.fail("curve points must be finite");
          curve.points.push_back(v);
        }
        std::stable_sort(curve.points.begin(), curve.points.end(), [](Vec2 x, Vec2 y) { return x.x < y.x; });
        d->curves.push_back(std::move(curve));
      }
    }
  }
  if (d->curves.empty())  // Blender's default: the identity on [0, 1]
    for (size_t i = 0; i < expected; ++i) d->curves.push_back(Curve{{{0.0f, 0.0f}, {1.0f, 1.0f}}});
  p.data = d;
}
void parse_rgb_curve(const PropReader& r, NodeProps& p) { parse_curves(r, p, 4); }
void parse_vector_curve(const PropReader& r, NodeProps& p) { parse_curves(r, p, 3); }
void parse_float_curve(const PropReader& r, NodeProps& p) { parse_curves(r, p, 1); }
void eval_rgb_curve(EvalArgs& a) {  // svm/ramp.h svm_node_curves: combined curve, then per channel
  const NodeData& d = *a.op.props.data;
  const Vec3 in = a.v(1);
  Vec3 c;
  for (int i = 0; i < 3; ++i) c[i] = d.curves[i].eval(d.curves[3].eval(in[i], d.extrapolate), d.extrapolate);
  a.out(0, lerp3(in, c, a.f(0)));
}
void eval_vector_curve(EvalArgs& a) {
  const NodeData& d = *a.op.props.data;
  const Vec3 in = a.v(1);
  Vec3 c;
  for (int i = 0; i < 3; ++i) c[i] = d.curves[i].eval(in[i], d.extrapolate);
  a.out(0, lerp3(in, c, a.f(0)));
}
void eval_float_curve(EvalArgs& a) {
  const NodeData& d = *a.op.props.data;
  const float in = a.f(1), t = a.f(0);
  a.out(0, in * (1.0f - t) + d.curves[0].eval(in, d.extrapolate) * t);
}

void eval_hue_saturation(EvalArgs& a) {  // svm/hsv.h
  const Vec3 in = a.v(4);
  Vec3 hsv = rgb_to_hsv(in);
  hsv.x = fract(hsv.x + a.f(0) + 0.5f);
  hsv.y = saturate(hsv.y * a.f(1));
  hsv.z *= a.f(2);
  const float fac = a.f(3);
  a.out(0, vmax3(hsv_to_rgb(hsv) * fac + in * (1.0f - fac), 0.0f));
}
void eval_invert(EvalArgs& a) {  // svm/invert.h
  const Vec3 c = a.v(1);
  a.out(0, lerp3(c, Vec3(1.0f) - c, a.f(0)));
}
void eval_gamma(EvalArgs& a) {  // svm/gamma.h
  const float g = a.f(1);
  a.out(0, map3(a.v(0), [g](float x) { return x > 0.0f ? std::pow(x, g) : x; }));
}
void eval_bright_contrast(EvalArgs& a) {  // svm/brightness.h
  const float bright = a.f(1), contrast = a.f(2);
  const float aa = 1.0f + contrast, b = bright - contrast * 0.5f;
  a.out(0, vmax3(a.v(0) * aa + Vec3(b), 0.0f));
}
void eval_rgb_to_bw(EvalArgs& a) { a.out(0, luminance(a.v(0))); }

// ---- Converter nodes ----

enum MathOp {
  kAdd_, kSubtract_, kMultiply_, kDivide_, kMultiplyAdd, kPower, kLogarithm, kSqrt, kInverseSqrt, kAbsolute,
  kExponent, kMinimum, kMaximum, kLessThan, kGreaterThan, kSign, kCompare, kSmoothMin, kSmoothMax, kRound,
  kFloor, kCeil, kTrunc, kFract, kModulo, kWrap, kSnap, kPingPong, kSine, kCosine, kTangent, kArcsine,
  kArccosine, kArctangent, kArctan2, kSinh, kCosh, kTanh, kRadians, kDegrees, kFlooredModulo
};
void parse_math(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("operation",
                    {"ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM", "SQRT",
                     "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN", "GREATER_THAN",
                     "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "ROUND", "FLOOR", "CEIL", "TRUNC", "FRACT",
                     "MODULO", "WRAP", "SNAP", "PINGPONG", "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE",
                     "ARCTANGENT", "ARCTAN2", "SINH", "COSH", "TANH", "RADIANS", "DEGREES", "FLOORED_MODULO"},
                    0);
  p.flag = r.boolean("use_clamp", false);
}
// svm/math_util.h svm_math.
float math_op(int op, float a, float b, float c) {
  switch (op) {
    case kAdd_: return a + b;
    case kSubtract_: return a - b;
    case kMultiply_: return a * b;
    case kDivide_: return safe_divide(a, b);
    case kMultiplyAdd: return a * b + c;
    case kPower:  // safe_powf
      if (a < 0.0f && b != static_cast<float>(static_cast<int>(b))) return 0.0f;
      return std::pow(a, b);
    case kLogarithm: return (a <= 0.0f || b <= 0.0f) ? 0.0f : safe_divide(std::log(a), std::log(b));
    case kSqrt: return a > 0.0f ? std::sqrt(a) : 0.0f;
    case kInverseSqrt: return a > 0.0f ? 1.0f / std::sqrt(a) : 0.0f;
    case kAbsolute: return std::abs(a);
    case kExponent: return std::exp(a);
    case kMinimum: return std::min(a, b);
    case kMaximum: return std::max(a, b);
    case kLessThan: return a < b ? 1.0f : 0.0f;
    case kGreaterThan: return a > b ? 1.0f : 0.0f;
    case kSign: return signf(a);
    case kCompare: return std::abs(a - b) <= std::max(c, 1e-5f) ? 1.0f : 0.0f;
    case kSmoothMin: return smoothminf(a, b, c);
    case kSmoothMax: return -smoothminf(-a, -b, c);
    case kRound: return std::floor(a + 0.5f);
    case kFloor: return std::floor(a);
    case kCeil: return std::ceil(a);
    case kTrunc: return a >= 0.0f ? std::floor(a) : std::ceil(a);
    case kFract: return a - std::floor(a);
    case kModulo: return b != 0.0f ? std::fmod(a, b) : 0.0f;
    case kFlooredModulo: return b != 0.0f ? a - std::floor(a / b) * b : 0.0f;
    case kWrap: return wrapf(a, b, c);
    case kSnap: return b != 0.0f ? std::floor(a / b) * b : 0.0f;
    case kPingPong: return pingpongf(a, b);
    case kSine: return std::sin(a);
    case kCosine: return std::cos(a);
    case kTangent: return std::tan(a);
    case kArcsine: return std::asin(std::clamp(a, -1.0f, 1.0f));
    case kArccosine: return std::acos(std::clamp(a, -1.0f, 1.0f));
    case kArctangent: return std::atan(a);
    case kArctan2: return std::atan2(a, b);
    case kSinh: return std::sinh(a);
    case kCosh: return std::cosh(a);
    case kTanh: return std::tanh(a);
    case kRadians: return a * (kPiF / 180.0f);
    case kDegrees: return a * (180.0f / kPiF);
  }
  return 0.0f;
}
void eval_math(EvalArgs& a) {
  float r = math_op(a.op.props.mode, a.f(0), a.f(1), a.f(2));
  if (a.op.props.flag) r = saturate(r);
  a.out(0, r);
}

enum VectorOp {
  vAdd, vSubtract, vMultiply, vDivide, vMultiplyAdd, vCross, vProject, vReflect, vRefract, vFaceforward, vDot,
  vDistance, vLength, vScale, vNormalize, vAbsolute, vMinimum, vMaximum, vFloor, vCeil, vFraction, vModulo, vWrap,
  vSnap, vSine, vCosine, vTangent
};
void parse_vector_math(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("operation",
                    {"ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT", "PROJECT", "REFLECT",
                     "REFRACT", "FACEFORWARD", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE", "NORMALIZE",
                     "ABSOLUTE", "MINIMUM", "MAXIMUM", "FLOOR", "CEIL", "FRACTION", "MODULO", "WRAP", "SNAP",
                     "SINE", "COSINE", "TANGENT"},
                    0);
}
void eval_vector_math(EvalArgs& a) {  // svm/math_util.h svm_vector_math
  const Vec3 A = a.v(0), B = a.v(1), C = a.v(2);
  const float s = a.f(3);
  Vec3 v;
  float f = 0.0f;
  switch (a.op.props.mode) {
    case vAdd: v = A + B; break;
    case vSubtract: v = A - B; break;
    case vMultiply: v = mul(A, B); break;
    case vDivide: v = safe_divide(A, B); break;
    case vMultiplyAdd: v = mul(A, B) + C; break;
    case vCross: v = cross(A, B); break;
    case vProject: {
      const float len_sq = dot(B, B);
      v = len_sq != 0.0f ? B * (dot(A, B) / len_sq) : kZero;
      break;
    }
    case vReflect: {
      const Vec3 n = safe_normalize(B);
      v = A - n * (2.0f * dot(n, A));
      break;
    }
    case vRefract: {
      const Vec3 n = safe_normalize(B);
      const float eta = s, d = dot(n, A);
      const float k = 1.0f - eta * eta * (1.0f - d * d);
      v = k < 0.0f ? kZero : A * eta - n * (eta * d + std::sqrt(k));
      break;
    }
    case vFaceforward: v = dot(C, B) < 0.0f ? A : -A; break;
    case vDot: f = dot(A, B); break;
    case vDistance: f = std::sqrt(dot(A - B, A - B)); break;
    case vLength: f = std::sqrt(dot(A, A)); break;
    case vScale: v = A * s; break;
    case vNormalize: v = safe_normalize(A); break;
    case vAbsolute: v = map3(A, [](float x) { return std::abs(x); }); break;
    case vMinimum: v = vmin(A, B); break;
    case vMaximum: v = vmax(A, B); break;
    case vFloor: v = map3(A, [](float x) { return std::floor(x); }); break;
    case vCeil: v = map3(A, [](float x) { return std::ceil(x); }); break;
    case vFraction: v = map3(A, [](float x) { return x - std::floor(x); }); break;
    case vModulo: v = Vec3(math_op(kModulo, A.x, B.x, 0), math_op(kModulo, A.y, B.y, 0), math_op(kModulo, A.z, B.z, 0)); break;
    case vWrap: v = Vec3(wrapf(A.x, B.x, C.x), wrapf(A.y, B.y, C.y), wrapf(A.z, B.z, C.z)); break;
    case vSnap: v = mul(map3(safe_divide(A, B), [](float x) { return std::floor(x); }), B); break;
    case vSine: v = map3(A, [](float x) { return std::sin(x); }); break;
    case vCosine: v = map3(A, [](float x) { return std::cos(x); }); break;
    case vTangent: v = map3(A, [](float x) { return std::tan(x); }); break;
  }
  a.out(0, v);
  a.out(1, f);
}

void parse_map_range(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("data_type", {"FLOAT", "FLOAT_VECTOR"}, 0);
  p.mode2 = r.choice("interpolation_type", {"LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP"}, 0);
  p.flag = r.boolean("clamp", true);
}
// svm/map_range.h: one component, the interpolation and clamp as there.
float map_range_1(int interp, bool clamp, float value, float from_min, float from_max, float to_min, float to_max,
                  float steps, bool vector) {
  float factor;
  if (!vector && from_max == from_min) return 0.0f;
  switch (interp) {
    case 1: {
      factor = vector ? safe_divide(value - from_min, from_max - from_min) : (value - from_min) / (from_max - from_min);
      factor = steps > 0.0f ? std::floor(factor * (steps + 1.0f)) / steps : 0.0f;
      break;
    }
    case 2:
      factor = from_min > from_max ? 1.0f - smoothstep(from_max, from_min, value) : smoothstep(from_min, from_max, value);
      break;
    case 3:
      factor = from_min > from_max ? 1.0f - smootherstep(from_max, from_min, value)
                                   : smootherstep(from_min, from_max, value);
      break;
    default:
      factor = vector ? safe_divide(value - from_min, from_max - from_min) : (value - from_min) / (from_max - from_min);
      break;
  }
  float result = to_min + factor * (to_max - to_min);
  if (clamp && (interp == 0 || interp == 1))
    result = to_min > to_max ? std::clamp(result, to_max, to_min) : std::clamp(result, to_min, to_max);
  return result;
}
void eval_map_range(EvalArgs& a) {
  const NodeProps& p = a.op.props;
  if (p.mode == 0) {
    const float steps = p.mode2 == 1 ? a.f(5) : 0.0f;  // read by Stepped alone
    a.out(0, map_range_1(p.mode2, p.flag, a.f(0), a.f(1), a.f(2), a.f(3), a.f(4), steps, false));
  } else {
    const Vec3 v = a.v(6), fmin = a.v(7), fmax = a.v(8), tmin = a.v(9), tmax = a.v(10), steps = a.v(11);
    Vec3 r;
    for (int i = 0; i < 3; ++i) r[i] = map_range_1(p.mode2, p.flag, v[i], fmin[i], fmax[i], tmin[i], tmax[i], steps[i], true);
    a.out(1, r);
  }
}

// Specialised Map Range (NodeType::specialize): Float, Linear, the interpolation switch decided
// at compile time; `Plain`: its five inputs need no conversion.
template <bool Clamp, bool Plain>
void eval_map_range_linear(EvalArgs& a) {
  auto f = [&](int i) { return Plain ? a.x(i) : a.f(i); };
  a.out(0, map_range_1(0, Clamp, f(0), f(1), f(2), f(3), f(4), 0.0f, false));
}
EvalFn specialize_map_range(const NodeProps& p, const InputSource* in, const uint32_t*) {
  if (p.mode != 0 || p.mode2 != 0) return nullptr;
  bool plain = true;
  for (int i = 0; i < 5; ++i) plain = plain && in[i].conv == Conversion::None;
  if (p.flag) return plain ? eval_map_range_linear<true, true> : eval_map_range_linear<true, false>;
  return plain ? eval_map_range_linear<false, true> : eval_map_range_linear<false, false>;
}

void parse_clamp(const PropReader& r, NodeProps& p) { p.mode = r.choice("clamp_type", {"MINMAX", "RANGE"}, 0); }
void eval_clamp(EvalArgs& a) {  // svm/clamp.h
  const float v = a.f(0), lo = a.f(1), hi = a.f(2);
  if (a.op.props.mode == 1 && lo > hi) a.out(0, std::clamp(v, hi, lo));
  else a.out(0, std::min(std::max(v, lo), hi));
}

void eval_separate3(EvalArgs& a) {
  const Vec3 c = a.v(0);
  a.out(0, c.x);
  a.out(1, c.y);
  a.out(2, c.z);
}
void eval_combine3(EvalArgs& a) { a.out(0, Vec3(a.f(0), a.f(1), a.f(2))); }
void eval_separate_hsv(EvalArgs& a) {
  const Vec3 h = rgb_to_hsv(a.v(0));
  a.out(0, h.x);
  a.out(1, h.y);
  a.out(2, h.z);
}
void eval_combine_hsv(EvalArgs& a) { a.out(0, hsv_to_rgb(Vec3(a.f(0), a.f(1), a.f(2)))); }
void parse_color_mode(const PropReader& r, NodeProps& p) { p.mode = r.choice("mode", {"RGB", "HSV", "HSL"}, 0); }
void eval_separate_color(EvalArgs& a) {  // svm/sepcomb_color.h
  Vec3 c = a.v(0);
  if (a.op.props.mode == 1) c = rgb_to_hsv(c);
  else if (a.op.props.mode == 2) c = rgb_to_hsl(c);
  a.out(0, c.x);
  a.out(1, c.y);
  a.out(2, c.z);
}
void eval_combine_color(EvalArgs& a) {
  Vec3 c(a.f(0), a.f(1), a.f(2));
  if (a.op.props.mode == 1) c = hsv_to_rgb(c);
  else if (a.op.props.mode == 2) c = hsl_to_rgb(c);
  a.out(0, c);
}

// Blackbody: Planck's law through the CIE 1931 observer (the analytic fit of core/spectrum) to
// Rec.709, normalised to luminance 1 as Cycles 3.4's svm_node_blackbody, which reads a fitted
// table of the same curve: within 0.02 of Cycles (tests/native/shading_procedural_test.cpp).
void eval_blackbody(EvalArgs& a) {
  const RGB c = blackbody_rec709(a.f(0));
  a.out(0, Vec3(c.r, c.g, c.b));
}
// Wavelength: the CIE colour of a wavelength in Rec.709 scaled by 1 / 2.52 and clipped at zero,
// as svm/wavelength.h (there from a 5 nm table between 380 and 780 nm, black outside).
void eval_wavelength(EvalArgs& a) {
  const float l = a.f(0);
  if (!(l >= 380.0f && l < 780.0f)) {
    a.out(0, kZero);
    return;
  }
  a.out(0, vmax3(xyz_to_rec709(cie_xyz_bar(l)) * (1.0f / 2.52f), 0.0f));
}

// ---- Vector nodes ----

void parse_mapping(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("vector_type", {"POINT", "TEXTURE", "VECTOR", "NORMAL"}, 0);
}
void eval_mapping(EvalArgs& a) {  // svm/mapping_util.h svm_mapping
  const Vec3 v = a.v(0), loc = a.v(1), scale = a.v(3);
  const Mat3 R = euler_to_mat(a.v(2));
  switch (a.op.props.mode) {
    case 0: a.out(0, R.apply(mul(v, scale)) + loc); break;
    case 1: a.out(0, safe_divide(R.apply_t(v - loc), scale)); break;
    case 2: a.out(0, R.apply(mul(v, scale))); break;
    default: a.out(0, safe_normalize(R.apply(safe_divide(v, scale)))); break;
  }
}

void parse_normal_map(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("space", {"TANGENT", "OBJECT", "WORLD", "BLENDER_OBJECT", "BLENDER_WORLD"}, 0);
}
void eval_normal_map(EvalArgs& a) {  // svm/normal.h... svm_node_normal_map
  const ShadingContext& c = a.ctx;
  Vec3 color = a.v(1) * 2.0f - Vec3(1.0f);
  const float strength = a.f(0);
  Vec3 N;
  switch (a.op.props.mode) {
    case 0: {
      // Tangent space: the tangent along u in the shading plane, the bitangent following v.
      const Vec3 tu = c.dPdu - c.N * dot(c.N, c.dPdu);
      if (!(dot(tu, tu) > 0.0f)) {
        a.out(0, c.N);
        return;
      }
      const Vec3 T = safe_normalize(tu);
      Vec3 B = cross(c.N, T);
      if (dot(B, c.dPdv) < 0.0f) B = -B;
      N = safe_normalize(T * color.x + B * color.y + c.N * color.z);
      break;
    }
    case 3:
    case 4:
      color.y = -color.y;
      color.z = -color.z;
      [[fallthrough]];
    default: {
      N = color;
      if (a.op.props.mode == 1 || a.op.props.mode == 3) {
        if (c.object) {
          const Transform& w = c.object->to_object;  // normals by the inverse transpose
          N = Vec3(w.m[0][0] * N.x + w.m[1][0] * N.y + w.m[2][0] * N.z, w.m[0][1] * N.x + w.m[1][1] * N.y + w.m[2][1] * N.z,
                   w.m[0][2] * N.x + w.m[1][2] * N.y + w.m[2][2] * N.z);
        }
      }
      N = safe_normalize(N);
      if (c.backfacing) N = -N;
      break;
    }
  }
  if (strength != 1.0f) N = safe_normalize(c.N + (N - c.N) * std::max(strength, 0.0f));
  if (!(dot(N, N) > 0.0f) || !std::isfinite(N.x + N.y + N.z)) N = c.N;
  a.out(0, N);
}

void parse_bump(const PropReader& r, NodeProps& p) { p.flag = r.boolean("invert", false); }
// svm/bump.h svm_node_set_bump: the height at the point and at two points moved along the
// surface (Cycles moves by the ray differentials; here by a small step along dP/du and dP/dv,
// to which the result is insensitive to first order).
void eval_bump(EvalArgs& a) {
  const ShadingContext& c = a.ctx;
  const Vec3 normal_in = a.v(3);
  Vec3 du = c.dPdu, dv = c.dPdv;
  if (!(dot(du, du) > 0.0f) || !(dot(dv, dv) > 0.0f) || !(dot(cross(du, dv), cross(du, dv)) > 0.0f)) {
    // No surface parametrisation: any tangent frame (uv does not move).
    const Vec3 n = c.N;
    const Vec3 t = std::abs(n.x) > 0.9f ? Vec3(0, 1, 0) : Vec3(1, 0, 0);
    du = safe_normalize(cross(t, n));
    dv = cross(n, du);
  }
  const float scale_p = std::max({1.0f, std::abs(c.P.x), std::abs(c.P.y), std::abs(c.P.z)});
  const float h = 1e-4f * scale_p;
  const float su = h / std::sqrt(dot(du, du)), sv = h / std::sqrt(dot(dv, dv));
  const bool has_uv = dot(c.dPdu, c.dPdu) > 0.0f;
  const Vec3 dPdx = du * su, dPdy = dv * sv;
  const float h_c = a.f(2);
  const float h_x = a.height_at(c.offset(dPdx, has_uv ? Vec2(su, 0.0f) : Vec2()));
  const float h_y = a.height_at(c.offset(dPdy, has_uv ? Vec2(0.0f, sv) : Vec2()));
  const Vec3 Rx = cross(dPdy, normal_in), Ry = cross(normal_in, dPdx);
  const float det = dot(dPdx, Rx);
  const Vec3 surfgrad = Rx * (h_x - h_c) + Ry * (h_y - h_c);
  const float strength = std::max(a.f(0), 0.0f);
  float dist = a.f(1);
  if (a.op.props.flag) dist = -dist;
  Vec3 n = normal_in * std::abs(det) - surfgrad * (dist * signf(det));
  if (!(dot(n, n) > 0.0f) || !std::isfinite(n.x + n.y + n.z)) {
    a.out(0, normal_in);
    return;
  }
  n = safe_normalize(n);
  n = safe_normalize(n * strength + normal_in * (1.0f - strength));
  a.out(0, n);
}

void parse_displacement(const PropReader& r, NodeProps& p) { p.mode = r.choice("space", {"OBJECT", "WORLD"}, 0); }
void eval_displacement(EvalArgs& a) {  // svm/displace.h svm_node_displacement
  const Vec3 N = a.v(3);
  const float height = a.f(0), mid = a.f(1), scale = a.f(2);
  Vec3 d;
  if (a.op.props.mode == 0 && a.ctx.object) {
    // Object space: along the object-space normal, scaled by the object's transform.
    const Vec3 no = normal_object(a.ctx);
    d = a.ctx.object->to_world.vector(no * ((height - mid) * scale));
  } else {
    d = N * ((height - mid) * scale);
  }
  a.out(0, d);
}

void parse_vector_transform(const PropReader& r, NodeProps& p) {
  p.mode = r.choice("vector_type", {"POINT", "VECTOR", "NORMAL"}, 1);
  p.mode2 = r.choice("convert_from", {"WORLD", "OBJECT", "CAMERA"}, 0);
  p.mode3 = r.choice("convert_to", {"WORLD", "OBJECT", "CAMERA"}, 1);
}
void eval_vector_transform(EvalArgs& a) {  // svm/vector_transform.h
  const ShadingContext& c = a.ctx;
  const int type = a.op.props.mode;
  Vec3 v = a.v(0);
  auto apply = [&](const Transform& t, bool inverse_of_normal, const Transform* inv) {
    if (type == 0) return t.point(v);
    if (type == 1) return t.vector(v);
    // Normals by the inverse transpose: the transpose of the inverse matrix.
    const Transform& m = *inv;
    (void)inverse_of_normal;
    return safe_normalize(Vec3(m.m[0][0] * v.x + m.m[1][0] * v.y + m.m[2][0] * v.z,
                               m.m[0][1] * v.x + m.m[1][1] * v.y + m.m[2][1] * v.z,
                               m.m[0][2] * v.x + m.m[1][2] * v.y + m.m[2][2] * v.z));
  };
  // To world first, then to the target.
  if (a.op.props.mode2 == 1 && c.object) v = apply(c.object->to_world, true, &c.object->to_object);
  if (a.op.props.mode2 == 2 && c.camera) v = apply(c.camera->camera_to_world, true, &c.camera->world_to_camera);
  if (a.op.props.mode3 == 1 && c.object) v = apply(c.object->to_object, true, &c.object->to_world);
  if (a.op.props.mode3 == 2 && c.camera)
    v = type == 0 ? c.camera->world_to_camera.point(v) : c.camera->world_to_camera.vector(v);
  a.out(0, v);
}

void parse_value(const PropReader& r, NodeProps& p) { (void)r, (void)p; }

// ---- The table ----

SocketDesc in_f(const char* id, float d) { return {id, F::Float, Vec3(d)}; }
SocketDesc in_c(const char* id, float r, float g, float b) { return {id, F::Color, Vec3(r, g, b)}; }
SocketDesc in_v(const char* id, float x = 0, float y = 0, float z = 0) { return {id, F::Vector, Vec3(x, y, z)}; }
SocketDesc in_imp(const char* id, Implicit i) { return {id, F::Vector, kZero, i}; }
SocketDesc out_f(const char* id) { return {id, F::Float, kZero}; }
SocketDesc out_c(const char* id) { return {id, F::Color, kZero}; }
SocketDesc out_v(const char* id) { return {id, F::Vector, kZero}; }

std::vector<NodeType> make_types() {
  std::vector<NodeType> t;
  auto add = [&](NodeType n) { t.push_back(std::move(n)); };
  const SocketDesc gen = in_imp("Vector", Implicit::Generated);
  // Input
  add({"ShaderNodeTexCoord", {}, {out_v("Generated"), out_v("Normal"), out_v("UV"), out_v("Object"), out_v("Camera"),
                                   out_v("Window"), out_v("Reflection")}, parse_tex_coord, eval_tex_coord, true});
  add({"ShaderNodeUVMap", {}, {out_v("UV")}, nullptr, eval_uv_map, true});
  add({"ShaderNodeVertexColor", {}, {out_c("Color"), out_f("Alpha")}, parse_color_attribute, eval_color_attribute,
       true});
  add({"ShaderNodeAttribute", {}, {out_c("Color"), out_v("Vector"), out_f("Fac"), out_f("Alpha")}, parse_attribute,
       eval_attribute, true});
  NodeType geometry{"ShaderNodeNewGeometry", {}, {out_v("Position"), out_v("Normal"), out_v("Tangent"),
                                                  out_v("True Normal"), out_v("Incoming"), out_v("Parametric"),
                                                  out_f("Backfacing"), out_f("Pointiness"), out_f("Random Per Island")},
                     nullptr, eval_geometry, true};
  geometry.reads_tangents = true;  // Tangent without an object
  add(std::move(geometry));
  add({"ShaderNodeObjectInfo", {}, {out_v("Location"), out_c("Color"), out_f("Alpha"), out_f("Object Index"),
                                     out_f("Material Index"), out_f("Random")}, nullptr, eval_object_info, true});
  add({"ShaderNodeFresnel", {in_f("IOR", 1.45f), in_imp("Normal", Implicit::Normal)}, {out_f("Fac")}, nullptr,
       eval_fresnel, true});
  add({"ShaderNodeLayerWeight", {in_f("Blend", 0.5f), in_imp("Normal", Implicit::Normal)},
       {out_f("Fresnel"), out_f("Facing")}, nullptr, eval_layer_weight, true});
  add({"ShaderNodeLightPath", {}, {out_f("Is Camera Ray"), out_f("Is Shadow Ray"), out_f("Is Diffuse Ray"),
                                    out_f("Is Glossy Ray"), out_f("Is Singular Ray"), out_f("Is Reflection Ray"),
                                    out_f("Is Transmission Ray"), out_f("Ray Length"), out_f("Ray Depth"),
                                    out_f("Diffuse Depth"), out_f("Glossy Depth"), out_f("Transparent Depth"),
                                    out_f("Transmission Depth")}, nullptr, eval_light_path, true});
  // Value and RGB: their value is the output's (written as the hidden input "Value" / "Color").
  add({"ShaderNodeValue", {in_f("Value", 0.5f)}, {out_f("Value")}, parse_value, eval_value});
  add({"ShaderNodeRGB", {in_c("Color", 0.5f, 0.5f, 0.5f)}, {out_c("Color")}, parse_value, eval_value});
  // Textures
  add({"ShaderNodeTexImage", {in_imp("Vector", Implicit::UV)}, {out_c("Color"), out_f("Alpha")}, parse_image,
       eval_tex_image, false});
  add({"ShaderNodeTexChecker", {gen, in_c("Color1", 0.8f, 0.8f, 0.8f), in_c("Color2", 0.2f, 0.2f, 0.2f),
                                 in_f("Scale", 5.0f)}, {out_c("Color"), out_f("Fac")}, nullptr, eval_tex_checker});
  add({"ShaderNodeTexNoise", {gen, in_f("W", 0.0f), in_f("Scale", 5.0f), in_f("Detail", 2.0f), in_f("Roughness", 0.5f),
                               in_f("Distortion", 0.0f)}, {out_f("Fac"), out_c("Color")}, parse_noise, eval_tex_noise});
  add({"ShaderNodeTexVoronoi", {gen, in_f("W", 0.0f), in_f("Scale", 5.0f), in_f("Smoothness", 1.0f),
                                 in_f("Exponent", 0.5f), in_f("Randomness", 1.0f)},
       {out_f("Distance"), out_c("Color"), out_v("Position"), out_f("W"), out_f("Radius")}, parse_voronoi,
       eval_tex_voronoi});
  add({"ShaderNodeTexMusgrave", {gen, in_f("W", 0.0f), in_f("Scale", 5.0f), in_f("Detail", 2.0f),
                                  in_f("Dimension", 2.0f), in_f("Lacunarity", 2.0f), in_f("Offset", 0.0f),
                                  in_f("Gain", 1.0f)}, {out_f("Fac")}, parse_musgrave, eval_tex_musgrave});
  add({"ShaderNodeTexWave", {gen, in_f("Scale", 5.0f), in_f("Distortion", 0.0f), in_f("Detail", 2.0f),
                              in_f("Detail Scale", 1.0f), in_f("Detail Roughness", 0.5f), in_f("Phase Offset", 0.0f)},
       {out_c("Color"), out_f("Fac")}, parse_wave, eval_tex_wave});
  add({"ShaderNodeTexGradient", {gen}, {out_c("Color"), out_f("Fac")}, parse_gradient, eval_tex_gradient});
  add({"ShaderNodeTexMagic", {gen, in_f("Scale", 5.0f), in_f("Distortion", 1.0f)}, {out_c("Color"), out_f("Fac")},
       parse_magic, eval_tex_magic});
  add({"ShaderNodeTexBrick", {gen, in_c("Color1", 0.8f, 0.8f, 0.8f), in_c("Color2", 0.2f, 0.2f, 0.2f),
                               in_c("Mortar", 0.0f, 0.0f, 0.0f), in_f("Scale", 5.0f), in_f("Mortar Size", 0.02f),
                               in_f("Mortar Smooth", 0.1f), in_f("Bias", 0.0f), in_f("Brick Width", 0.5f),
                               in_f("Row Height", 0.25f)}, {out_c("Color"), out_f("Fac")}, parse_brick,
       eval_tex_brick});
  add({"ShaderNodeTexEnvironment", {gen}, {out_c("Color"), out_f("Alpha")}, parse_tex_environment,
       eval_tex_environment});
  add({"ShaderNodeTexSky", {gen}, {out_c("Color")}, parse_tex_sky, eval_tex_sky});
  add({"ShaderNodeTexWhiteNoise", {in_imp("Vector", Implicit::Position), in_f("W", 0.0f)},
       {out_f("Value"), out_c("Color")}, parse_white_noise, eval_tex_white_noise});
  // Colour
  add({"ShaderNodeMixRGB", {in_f("Fac", 0.5f), in_c("Color1", 0.5f, 0.5f, 0.5f), in_c("Color2", 0.5f, 0.5f, 0.5f)},
       {out_c("Color")}, parse_mix_rgb, eval_mix_rgb});
  add({"ShaderNodeMix", {in_f("Factor_Float", 0.5f), in_v("Factor_Vector", 0.5f, 0.5f, 0.5f), in_f("A_Float", 0.0f),
                         in_f("B_Float", 0.0f), in_v("A_Vector"), in_v("B_Vector"), in_c("A_Color", 0.5f, 0.5f, 0.5f),
                         in_c("B_Color", 0.5f, 0.5f, 0.5f)},
       {out_f("Result_Float"), out_v("Result_Vector"), out_c("Result_Color")}, parse_mix, eval_mix});
  add({"ShaderNodeValToRGB", {in_f("Fac", 0.5f)}, {out_c("Color"), out_f("Alpha")}, parse_color_ramp, eval_color_ramp});
  add({"ShaderNodeRGBCurve", {in_f("Fac", 1.0f), in_c("Color", 1.0f, 1.0f, 1.0f)}, {out_c("Color")}, parse_rgb_curve,
       eval_rgb_curve});
  add({"ShaderNodeVectorCurve", {in_f("Fac", 1.0f), in_v("Vector")}, {out_v("Vector")}, parse_vector_curve,
       eval_vector_curve});
  add({"ShaderNodeFloatCurve", {in_f("Factor", 1.0f), in_f("Value", 1.0f)}, {out_f("Value")}, parse_float_curve,
       eval_float_curve});
  add({"ShaderNodeHueSaturation", {in_f("Hue", 0.5f), in_f("Saturation", 1.0f), in_f("Value", 1.0f), in_f("Fac", 1.0f),
                                    in_c("Color", 0.8f, 0.8f, 0.8f)}, {out_c("Color")}, nullptr, eval_hue_saturation});
  add({"ShaderNodeInvert", {in_f("Fac", 1.0f), in_c("Color", 0.0f, 0.0f, 0.0f)}, {out_c("Color")}, nullptr, eval_invert});
  add({"ShaderNodeGamma", {in_c("Color", 1.0f, 1.0f, 1.0f), in_f("Gamma", 1.0f)}, {out_c("Color")}, nullptr, eval_gamma});
  add({"ShaderNodeBrightContrast", {in_c("Color", 1.0f, 1.0f, 1.0f), in_f("Bright", 0.0f), in_f("Contrast", 0.0f)},
       {out_c("Color")}, nullptr, eval_bright_contrast});
  add({"ShaderNodeRGBToBW", {in_c("Color", 0.5f, 0.5f, 0.5f)}, {out_f("Val")}, nullptr, eval_rgb_to_bw});
  // Converter
  add({"ShaderNodeMath", {in_f("Value", 0.5f), in_f("Value_001", 0.5f), in_f("Value_002", 0.5f)}, {out_f("Value")},
       parse_math, eval_math});
  add({"ShaderNodeVectorMath", {in_v("Vector"), in_v("Vector_001"), in_v("Vector_002"), in_f("Scale", 1.0f)},
       {out_v("Vector"), out_f("Value")}, parse_vector_math, eval_vector_math});
  add({"ShaderNodeMapRange", {in_f("Value", 1.0f), in_f("From Min", 0.0f), in_f("From Max", 1.0f), in_f("To Min", 0.0f),
                              in_f("To Max", 1.0f), in_f("Steps", 4.0f), in_v("Vector"), in_v("From_Min_FLOAT3"),
                              in_v("From_Max_FLOAT3", 1, 1, 1), in_v("To_Min_FLOAT3"), in_v("To_Max_FLOAT3", 1, 1, 1),
                              in_v("Steps_FLOAT3", 4, 4, 4)},
       {out_f("Result"), out_v("Vector")}, parse_map_range, eval_map_range});
  add({"ShaderNodeClamp", {in_f("Value", 1.0f), in_f("Min", 0.0f), in_f("Max", 1.0f)}, {out_f("Result")}, parse_clamp,
       eval_clamp});
  add({"ShaderNodeSeparateRGB", {in_c("Image", 0.8f, 0.8f, 0.8f)}, {out_f("R"), out_f("G"), out_f("B")}, nullptr,
       eval_separate3});
  add({"ShaderNodeCombineRGB", {in_f("R", 0.0f), in_f("G", 0.0f), in_f("B", 0.0f)}, {out_c("Image")}, nullptr,
       eval_combine3});
  add({"ShaderNodeSeparateXYZ", {in_v("Vector")}, {out_f("X"), out_f("Y"), out_f("Z")}, nullptr, eval_separate3});
  add({"ShaderNodeCombineXYZ", {in_f("X", 0.0f), in_f("Y", 0.0f), in_f("Z", 0.0f)}, {out_v("Vector")}, nullptr,
       eval_combine3});
  add({"ShaderNodeSeparateHSV", {in_c("Color", 0.8f, 0.8f, 0.8f)}, {out_f("H"), out_f("S"), out_f("V")}, nullptr,
       eval_separate_hsv});
  add({"ShaderNodeCombineHSV", {in_f("H", 0.0f), in_f("S", 0.0f), in_f("V", 0.0f)}, {out_c("Color")}, nullptr,
       eval_combine_hsv});
  add({"ShaderNodeSeparateColor", {in_c("Color", 0.8f, 0.8f, 0.8f)}, {out_f("Red"), out_f("Green"), out_f("Blue")},
       parse_color_mode, eval_separate_color});
  add({"ShaderNodeCombineColor", {in_f("Red", 0.0f), in_f("Green", 0.0f), in_f("Blue", 0.0f)}, {out_c("Color")},
       parse_color_mode, eval_combine_color});
  add({"ShaderNodeBlackbody", {in_f("Temperature", 1500.0f)}, {out_c("Color")}, nullptr, eval_blackbody});
  add({"ShaderNodeWavelength", {in_f("Wavelength", 500.0f)}, {out_c("Color")}, nullptr, eval_wavelength});
  // Vector
  add({"ShaderNodeMapping", {in_v("Vector"), in_v("Location"), in_v("Rotation"), in_v("Scale", 1, 1, 1)},
       {out_v("Vector")}, parse_mapping, eval_mapping});
  NodeType normal_map{"ShaderNodeNormalMap", {in_f("Strength", 1.0f), in_c("Color", 0.5f, 0.5f, 1.0f)},
                      {out_v("Normal")}, parse_normal_map, eval_normal_map, true};
  normal_map.reads_tangents = true;
  add(std::move(normal_map));
  NodeType bump{"ShaderNodeBump", {in_f("Strength", 1.0f), in_f("Distance", 1.0f), in_f("Height", 1.0f),
                                   in_imp("Normal", Implicit::Normal)}, {out_v("Normal")}, parse_bump, eval_bump, true};
  bump.height_input = 2;
  bump.reads_tangents = true;
  add(std::move(bump));
  add({"ShaderNodeDisplacement", {in_f("Height", 0.0f), in_f("Midlevel", 0.5f), in_f("Scale", 1.0f),
                                  in_imp("Normal", Implicit::Normal)}, {out_v("Displacement")}, parse_displacement,
       eval_displacement, true});
  add({"ShaderNodeVectorTransform", {in_v("Vector", 0.5f, 0.5f, 0.5f)}, {out_v("Vector")}, parse_vector_transform,
       eval_vector_transform, true});
  for (NodeType& n : t) {
    if (std::string(n.idname) == "ShaderNodeMix") n.specialize = specialize_mix;
    if (std::string(n.idname) == "ShaderNodeMapRange") n.specialize = specialize_map_range;
    if (std::string(n.idname) == "ShaderNodeTexNoise") n.specialize = specialize_noise;
    if (std::string(n.idname) == "ShaderNodeTexCoord") n.specialize = specialize_tex_coord;
  }
  std::sort(t.begin(), t.end(), [](const NodeType& x, const NodeType& y) { return std::string(x.idname) < y.idname; });
  return t;
}

const NodeType kImplicit{"(implicit input)", {}, {out_v("Value")}, nullptr, eval_implicit, true};

}  // namespace

float Curve::eval(float x, bool extrapolate) const {
  const size_t n = points.size();
  if (n == 1) return points[0].y;
  if (!std::isfinite(x)) return points[0].y;
  if (x <= points[0].x) {
    if (!extrapolate) return points[0].y;
    const Vec2 a = points[0], b = points[1];
    return b.x != a.x ? a.y + (x - a.x) * (b.y - a.y) / (b.x - a.x) : a.y;
  }
  if (x >= points[n - 1].x) {
    if (!extrapolate) return points[n - 1].y;
    const Vec2 a = points[n - 2], b = points[n - 1];
    return b.x != a.x ? b.y + (x - b.x) * (b.y - a.y) / (b.x - a.x) : b.y;
  }
  const auto it = std::upper_bound(points.begin(), points.end(), x, [](float v, const Vec2& p) { return v < p.x; });
  const Vec2 b = *it, a = *(it - 1);
  return b.x != a.x ? a.y + (x - a.x) * (b.y - a.y) / (b.x - a.x) : b.y;
}

const std::vector<NodeType>& node_types() {
  static const std::vector<NodeType> types = make_types();
  return types;
}

const NodeType* find_node_type(const std::string& idname) {
  const auto& t = node_types();
  const auto it = std::lower_bound(t.begin(), t.end(), idname,
                                   [](const NodeType& n, const std::string& s) { return n.idname < s; });
  return it != t.end() && it->idname == idname ? &*it : nullptr;
}

const NodeType* implicit_node_type() { return &kImplicit; }

std::vector<std::string> supported_node_types() {
  std::vector<std::string> names;
  for (const NodeType& t : node_types()) names.emplace_back(t.idname);
  return names;
}

}  // namespace gp::shading
