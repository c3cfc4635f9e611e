#include "lights/light.h"

#include "core/frame.h"
#include "lights/world_graph.h"
#include "textures/normal_mapping.h"

namespace gp {

LightSet::LightSet(std::vector<Light> lights, const Bounds3& scene_bounds)
    : lights_(std::move(lights)) {
  scene_radius_ = scene_bounds.empty() ? 1.0f : 0.5f * length(scene_bounds.diagonal());
  if (!(scene_radius_ > 0)) scene_radius_ = 1.0f;
  scene_center_ = scene_bounds.empty() ? Vec3() : scene_bounds.center();
  std::vector<float> weights;
  for (size_t i = 0; i < lights_.size(); ++i) {
    if (lights_[i].type == LightType::Environment) environment_ = static_cast<int>(i);
    weights.push_back(power(static_cast<int>(i)));
    if ((lights_[i].type == LightType::Point || lights_[i].type == LightType::Spot) && lights_[i].radius > 0)
      disk_lights_.push_back(static_cast<int>(i));
  }
  if (!weights.empty()) select_ = DiscreteDistribution(weights);
}

namespace {
// A light where it is at the thread's shutter time (core/math.h), for a moving one: a copy with
// its triangle, normal and area (an emissive triangle of a moving mesh) or its point and axis (a
// moving lamp) at that time. The light is sampled uniformly on the triangle it is at that time,
// so the area pdf is 1 / A(t): exact for rigid motion (A constant) and for deformation and
// animated scale alike (A(t) changes, the pdf with it); its selection probability stays the
// frame's power, any fixed choice being unbiased. Out of line: still scenes never call it.
[[gnu::noinline]] Light moved_at_shutter_time(const Light& l) {
  Light moved = l;
  if (l.lamp_motion) {  // a moving lamp: its own point and axis under its transform at that time
    const Transform m = l.lamp_motion->at(shutter_time());
    moved.position = m.point(l.local_position);
    const Vec3 d = m.vector(l.local_direction);
    if (length_squared(d) > 0) moved.direction = normalize(d);
    return moved;
  }
  Vec3 v[3];
  l.motion->triangle(l.tri, shutter_time(), v);
  const Vec3 nc = cross(v[1] - v[0], v[2] - v[0]);
  const float area = 0.5f * length(nc);
  moved.p0 = v[0];
  moved.p1 = v[1];
  moved.p2 = v[2];
  if (area > 0 && std::isfinite(area)) {
    moved.area = area;
    moved.n = nc / (2.0f * area);
  }
  return moved;
}
bool moves(const Light& l) { return l.lamp_motion || l.motion; }
// f(the light at the thread's shutter time): a still light is passed as it is, with nothing
// copied or constructed (a still scene's path tracing paid 1-2 % for an optional copy per query).
template <class F>
decltype(auto) with_light_at_shutter_time(const Light& l, F&& f) {
  if (!moves(l)) [[likely]] return f(l);
  const Light moved = moved_at_shutter_time(l);
  return f(moved);
}
}  // namespace

float LightSet::power(int i) const {
  const Light& l = lights_[i];
  const float e = l.emit.average();
  const float r2 = scene_radius_ * scene_radius_;
  switch (l.type) {
    case LightType::Area: return e * l.area * kPi * (l.two_sided ? 2.0f : 1.0f);
    case LightType::Point: return 4.0f * kPi * e;
    case LightType::Spot: return 2.0f * kPi * e * (1.0f - l.spot_cos_half);
    case LightType::Directional: return kPi * r2 * e;
    case LightType::Environment: return kPi * r2 * (l.map ? l.map->integral().average() : 4.0f * kPi * e);
  }
  return 0.0f;
}

float LightSet::spot_falloff(const Light& l, const Vec3& w_from_light) const {
  // Blender/Cycles spot: cosine to the axis, cut at the cone, smoothstep blend at the edge.
  const float c = dot(w_from_light, l.direction);
  if (c <= l.spot_cos_half) return 0.0f;
  const float t = c - l.spot_cos_half;
  float atten = c;
  if (l.spot_smooth > 0 && t < l.spot_smooth) {
    const float s = t / l.spot_smooth;
    atten *= s * s * (3.0f - 2.0f * s);
  }
  return atten;
}

std::optional<LightSample> LightSet::sample_li(const Vec3& p, float u_select, Vec2 u) const {
  if (select_.empty()) return std::nullopt;
  float u_rest;
  const int i = static_cast<int>(select_.sample(u_select, &u_rest));
  const float pmf = select_.pmf(i);
  return with_light_at_shutter_time(lights_[i], [&](const Light& l) -> std::optional<LightSample> {
    LightSample s;
    s.light = i;
    switch (l.type) {
      case LightType::Area: {
        const Vec2 b = sample_uniform_triangle(u);
        const Vec3 q = l.p0 * b.x + l.p1 * b.y + l.p2 * (1.0f - b.x - b.y);
        const Vec3 d = q - p;
        const float d2 = length_squared(d);
        if (d2 <= 0) return std::nullopt;
        s.dist = std::sqrt(d2);
        s.wi = d / s.dist;
        const float cos_l = -dot(l.n, s.wi);
        if (!l.two_sided && cos_l <= 0) return std::nullopt;
        if (cos_l == 0) return std::nullopt;
        s.L = l.emission_graph ? l.emission_graph->at(l, q, -s.wi) : l.emit;
        s.p = q;
        s.n = l.n;
        s.pdf = pmf * d2 / (std::abs(cos_l) * l.area);  // area pdf 1/A to solid angle
        return s;
      }
      case LightType::Point:
      case LightType::Spot: {
        Vec3 q = l.position;
        float cos_l = 1.0f;
        if (l.radius > 0) {
          // Cycles' sphere light: a uniform point on the disk of radius r facing p, radiance
          // I / (pi r^2); divided by the area pdf 1 / (pi r^2) the sample carries I cos_l / d^2.
          const Vec3 to_p = p - l.position;
          if (length_squared(to_p) <= 0) return std::nullopt;
          const Frame f(normalize(to_p));
          const Vec2 disk = sample_uniform_disk_concentric(u) * l.radius;
          q = l.position + f.s * disk.x + f.t * disk.y;
          const Vec3 w = normalize(p - q);
          cos_l = dot(w, f.n);
        }
        const Vec3 d = q - p;
        const float d2 = length_squared(d);
        if (d2 <= 0 || cos_l <= 0) return std::nullopt;
        s.dist = std::sqrt(d2);
        s.wi = d / s.dist;
        float scale = cos_l;
        if (l.type == LightType::Spot) scale *= spot_falloff(l, -s.wi);
        if (scale <= 0) return std::nullopt;
        s.L = l.emit * (scale / d2);
        s.pdf = pmf;
        s.delta = true;
        if (l.radius > 0) s.mis_pdf = pmf * d2 / (cos_l * kPi * l.radius * l.radius);
        return s;
      }
      case LightType::Directional:
        s.wi = -l.direction;
        if (l.sun_tan_half > 0) {
          // Cycles' distant light of angle a: a point on the disk of radius tan(a/2) at unit
          // distance; its pdf and eval_fac are equal, so the sample carries the irradiance.
          const Frame f(s.wi);
          const Vec2 disk = sample_uniform_disk_concentric(u) * l.sun_tan_half;
          s.wi = normalize(s.wi + f.s * disk.x + f.t * disk.y);
        }
        s.L = l.emit;
        s.pdf = pmf;
        s.delta = true;
        return s;
      case LightType::Environment:
        if (l.map) {  // the map's luminance x sin(theta) distribution (environment_map.h)
          float pdf_dir = 0;
          if (!l.map->sample_eval(u, &s.wi, &pdf_dir, &s.L)) return std::nullopt;
          s.pdf = pmf * pdf_dir;
          return s;
        }
        s.wi = sample_uniform_sphere(u);
        s.L = l.emit;
        s.pdf = pmf * uniform_sphere_pdf();
        return s;
    }
    return std::nullopt;
  });
}

std::optional<Vec3> LightSet::sample_position(float u_select, Vec2 u, int* light) const {
  *light = -1;
  if (select_.empty()) return std::nullopt;
  float u_rest;
  *light = static_cast<int>(select_.sample(u_select, &u_rest));
  return with_light_at_shutter_time(lights_[*light], [&](const Light& l) -> std::optional<Vec3> {
    switch (l.type) {
      case LightType::Area: {
        const Vec2 b = sample_uniform_triangle(u);
        return l.p0 * b.x + l.p1 * b.y + l.p2 * (1.0f - b.x - b.y);
      }
      case LightType::Point:
      case LightType::Spot:
        return l.position;
      default:
        return std::nullopt;
    }
  });
}

float LightSet::pdf_area(int i, const Vec3& p, const Vec3& p_light, const Vec3& wi) const {
  return with_light_at_shutter_time(lights_[i], [&](const Light& l) -> float {
    const float cos_l = -dot(l.n, wi);
    if (cos_l == 0 || (!l.two_sided && cos_l < 0)) return 0.0f;
    return select_.pmf(i) * length_squared(p_light - p) / (std::abs(cos_l) * l.area);
  });
}

float LightSet::pdf_environment(const Vec3& wi) const {
  if (environment_ < 0) return 0.0f;
  const Light& l = lights_[environment_];
  return select_.pmf(environment_) * (l.map ? l.map->pdf(wi) : uniform_sphere_pdf());
}

RGB LightSet::environment_radiance(const Vec3& dir, bool camera_ray) const {
  if (environment_ < 0) return RGB(0.0f);
  const Light& l = lights_[environment_];
  if (camera_ray && l.camera_override) return l.camera_map ? l.camera_map->eval(dir) : l.camera_emit;
  if (!l.map) return l.emit;
  return camera_ray ? l.map->eval(dir, RayState::camera()) : l.map->eval(dir);  // a World graph's Light Path
}

RGB LightSet::environment_radiance(const Ray& ray) const {
  if (environment_ < 0) return RGB(0.0f);
  const Light& l = lights_[environment_];
  RayState state = ray.state;
  if (ray.camera) state.flags |= kPathCamera;
  const WorldRayOrigin origin(ray.o);  // Window of an orthographic camera's rays (world_graph.h)
  if (ray.camera && l.camera_override) return l.camera_map ? l.camera_map->eval(ray.d, state) : l.camera_emit;
  return l.map ? l.map->eval(ray.d, state) : l.emit;
}

RGB LightSet::environment_radiance(const Ray& ray, float* pdf) const {
  if (environment_ < 0) {
    *pdf = 0.0f;
    return RGB(0.0f);
  }
  const Light& l = lights_[environment_];
  if (!l.map || (ray.camera && l.camera_override)) {
    *pdf = pdf_environment(ray.d);
    return environment_radiance(ray);
  }
  RayState state = ray.state;  // as environment_radiance(ray) sees it
  if (ray.camera) state.flags |= kPathCamera;
  const WorldRayOrigin origin(ray.o);
  float pdf_dir = 0;
  const RGB Le = l.map->eval_pdf(ray.d, state, &pdf_dir);  // one projection for both
  *pdf = select_.pmf(environment_) * pdf_dir;
  return Le;
}

int LightSet::intersect_disk(const Ray& ray, float tmax, float* t_hit, RGB* L, float* pdf) const {
  int found = -1;
  for (int i : disk_lights_) {
    std::optional<Light> moved;  // a moving disk light's copy at the shutter time
    if (moves(lights_[i])) moved = moved_at_shutter_time(lights_[i]);
    const Light& l = moved ? *moved : lights_[i];
    const Vec3 to_o = ray.o - l.position;
    const float d2 = length_squared(to_o);
    const float r2 = l.radius * l.radius;
    if (d2 <= 0) continue;
    const Vec3 n = to_o / std::sqrt(d2);  // the disk faces the ray's origin
    const float cos_l = -dot(ray.d, n);
    if (cos_l <= 0) continue;
    const float t = dot(to_o, n) / cos_l;  // plane through the centre, normal n
    if (!(t > ray.tmin && t < tmax)) continue;
    if (length_squared(ray.at(t) - l.position) > r2) continue;
    float scale = 1.0f;
    if (l.type == LightType::Spot) scale = spot_falloff(l, -ray.d);
    if (scale <= 0) continue;
    tmax = t;
    found = i;
    *t_hit = t;
    *L = l.emit * (scale / (kPi * r2));  // intensity spread over the disk: radiance
    *pdf = select_.pmf(i) * t * t / (cos_l * kPi * r2);
  }
  return found;
}

RGB LightSet::area_radiance(int i, const Vec3& w) const {
  return with_light_at_shutter_time(lights_[i], [&](const Light& l) -> RGB {
    const float c = dot(l.n, w);
    return (c > 0 || (l.two_sided && c < 0)) ? l.emit : RGB(0.0f);
  });
}

RGB LightSet::area_radiance(int i, const Vec3& w, const Vec3& p, const RayState* ray) const {
  return with_light_at_shutter_time(lights_[i], [&](const Light& l) -> RGB {
    const float c = dot(l.n, w);
    if (!(c > 0 || (l.two_sided && c < 0))) return RGB(0.0f);
    return l.emission_graph ? l.emission_graph->at(l, p, w, ray) : l.emit;
  });
}

RGB EmissionGraph::at(const Light& l, const Vec3& p, const Vec3& wo, const RayState* ray) const {
  // Barycentrics of p in the light's triangle, for its uv.
  const Vec3 e1 = l.p1 - l.p0, e2 = l.p2 - l.p0, d = p - l.p0;
  const float d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2), dp1 = dot(d, e1), dp2 = dot(d, e2);
  const float det = d11 * d22 - d12 * d12;
  const float b1 = det != 0 ? (d22 * dp1 - d12 * dp2) / det : 0.0f, b2 = det != 0 ? (d11 * dp2 - d12 * dp1) / det : 0.0f;
  shading::ShadingContext ctx;
  ctx.P = p;
  ctx.uv = uv0 * (1 - b1 - b2) + uv1 * b1 + uv2 * b2;
  ctx.bary = Vec2(b1, b2);
  ctx.backfacing = dot(l.n, wo) < 0;
  ctx.N = ctx.Ng = ctx.backfacing ? -l.n : l.n;
  ctx.I = wo;
  ctx.object = object;
  // A light moving with its object: the emission's Object coordinates at the thread's time.
  if (object && l.motion && !l.motion->transform.empty()) ctx.set_object_at(*object, l.motion->transform.at(shutter_time()));
  ctx.prim = prim;
  ctx.camera = camera;
  // The triangle's surface tangents where the graph reads them (Normal Map, Bump, Geometry's
  // Tangent), as Scene::shading_context gives a surface's: without them a bumped or normal-mapped
  // emission read the plain normal (test_nodes_render_more.py against Cycles).
  if (program->reads_tangents() && !triangle_dpduv(l.p0, l.p1, l.p2, uv0, uv1, uv2, &ctx.dPdu, &ctx.dPdv))
    ctx.dPdu = ctx.dPdv = Vec3(0.0f);
  if (ray) ctx.ray = *ray;
  thread_local std::vector<Vec3> regs;
  regs.resize(program->num_registers());
  program->run(ctx, regs.data());
  RGB e = emission_constant;
  if (emission_linked) {
    const Vec3& v = regs[emission.reg];
    e = RGB(v.x, v.y, v.z);
  }
  float s = strength_constant;
  if (strength_linked) s = shading::as_float(regs[strength.reg], strength.conv);
  RGB r = e * s;
  for (int k = 0; k < 3; ++k) r[k] = std::isfinite(r[k]) ? std::max(r[k], 0.0f) : 0.0f;  // NaN/Inf never reach a pass
  return r;
}

RGB LightSet::emitted(int i, const Vec3& d) const {
  return with_light_at_shutter_time(lights_[i], [&](const Light& l) -> RGB {
    switch (l.type) {
      case LightType::Area: return area_radiance(i, d) * std::abs(dot(l.n, d));
      case LightType::Point: return l.emit;
      case LightType::Spot: return l.emit * spot_falloff(l, d);
      case LightType::Directional:
      case LightType::Environment: return RGB(0.0f);
    }
    return RGB(0.0f);
  });
}

Vec3 LightSet::position(int i) const {
  return with_light_at_shutter_time(lights_[i], [](const Light& l) { return l.position; });
}

void LightSet::emission_pdf(int i, const Vec3& d, float& pdf_pos, float& pdf_dir) const {
  return with_light_at_shutter_time(lights_[i], [&](const Light& l) -> void {
    const float pmf = select_.pmf(i);
    pdf_pos = pdf_dir = 0;
    switch (l.type) {
      case LightType::Area: {
        const float c = dot(l.n, d);
        if (c == 0 || (!l.two_sided && c < 0)) return;
        pdf_pos = pmf / l.area;
        pdf_dir = std::abs(c) * kInvPi * (l.two_sided ? 0.5f : 1.0f);
        return;
      }
      case LightType::Point:
        pdf_pos = pmf;
        pdf_dir = uniform_sphere_pdf();
        return;
      case LightType::Spot:
        pdf_pos = pmf;
        pdf_dir = dot(d, l.direction) >= l.spot_cos_half ? uniform_cone_pdf(l.spot_cos_half) : 0.0f;
        return;
      case LightType::Directional:
        pdf_pos = 1.0f / (kPi * scene_radius_ * scene_radius_);
        pdf_dir = pmf;
        return;
      case LightType::Environment:  // radiance arrives from -d
        pdf_pos = 1.0f / (kPi * scene_radius_ * scene_radius_);
        pdf_dir = pmf * (l.map ? l.map->pdf(-d) : uniform_sphere_pdf());
        return;
    }
  });
}

// Where a photon of a point or spot light leaves it along unit d: the centre, or for a light of
// radius r > 0 (Cycles' sphere light, which sample_li and intersect_disk see as a disk of radius r
// facing the shading point, radiance I falloff / (pi r^2)) a uniform point of the disk of radius r
// perpendicular to d through the centre: the rays along d that leave the light cross that disk
// uniformly, and its intensity along d is still I falloff(d), so the photon's power is the point
// light's. Photons from the centre alone focused a glass sphere's caustic as a point light does,
// sharper than the disk that pt and Cycles render (scenes/volumetric-caustic.json).
static Vec3 emission_origin(const Light& l, const Vec3& d, Vec2 u_pos) {
  if (!(l.radius > 0)) return l.position;
  const Frame f(d);
  const Vec2 disk = sample_uniform_disk_concentric(u_pos) * l.radius;
  return l.position + f.s * disk.x + f.t * disk.y;
}

std::optional<PhotonEmission> LightSet::sample_le(float u_select, Vec2 u_pos, Vec2 u_dir) const {
  if (select_.empty()) return std::nullopt;
  const int i = static_cast<int>(select_.sample(u_select));
  const float pmf = select_.pmf(i);
  if (!(pmf > 0)) return std::nullopt;
  return with_light_at_shutter_time(lights_[i], [&](const Light& l) -> std::optional<PhotonEmission> {
    PhotonEmission e;
    e.light = i;
    switch (l.type) {
      case LightType::Area: {
        // Le cos / (pdf_pos * pdf_dir) = Le cos / ((1/A) (cos/pi)) = Le pi A (per side).
        const Vec2 b = sample_uniform_triangle(u_pos);
        e.o = l.p0 * b.x + l.p1 * b.y + l.p2 * (1.0f - b.x - b.y);
        Vec3 n = l.n;
        float side_scale = 1.0f;
        if (l.two_sided) {  // pick a face with probability 1/2, reusing the first direction number
          if (u_dir.x < 0.5f) {
            u_dir.x *= 2.0f;
          } else {
            u_dir.x = std::min(2.0f * u_dir.x - 1.0f, 0x1.fffffep-1f);
            n = -n;
          }
          side_scale = 2.0f;
        }
        const Vec3 local = sample_cosine_hemisphere(u_dir);
        if (local.z <= 0) return std::nullopt;
        e.d = normalize(Frame(n).to_world(local));
        e.n = n;
        e.power = (l.emission_graph ? l.emission_graph->at(l, e.o, e.d) : l.emit) * (kPi * l.area * side_scale / pmf);
        emission_pdf(i, e.d, e.pdf_pos, e.pdf_dir);
        return e;
      }
      case LightType::Point:
        e.d = sample_uniform_sphere(u_dir);
        e.o = emission_origin(l, e.d, u_pos);
        e.power = l.emit * (1.0f / (uniform_sphere_pdf() * pmf));
        emission_pdf(i, e.d, e.pdf_pos, e.pdf_dir);
        return e;
      case LightType::Spot: {
        // Uniform directions in the cone, weighted by the falloff (which includes the cosine
        // to the axis and the smoothstep blend), exactly the intensity sample_li sees.
        const Vec3 local = sample_uniform_cone(u_dir, l.spot_cos_half);
        e.d = normalize(Frame(l.direction).to_world(local));
        e.o = emission_origin(l, e.d, u_pos);
        const float falloff = spot_falloff(l, e.d);
        if (!(falloff > 0)) return std::nullopt;
        e.power = l.emit * (falloff / (uniform_cone_pdf(l.spot_cos_half) * pmf));
        emission_pdf(i, e.d, e.pdf_pos, e.pdf_dir);
        return e;
      }
      case LightType::Directional:
      case LightType::Environment: {
        // Direction of travel, then a point on the disk of radius r perpendicular to it,
        // centred on the scene and pushed back by r so the whole scene lies ahead of it.
        const float r = scene_radius_;
        float dir_pdf = 1.0f;
        Vec3 d = l.direction;
        RGB radiance = l.emit;
        if (l.type == LightType::Environment && l.map) {
          // The map's own distribution, as next-event estimation draws it (environment_map.h).
          Vec3 wi;
          if (!l.map->sample(u_dir, &wi, &dir_pdf)) return std::nullopt;
          d = -wi;
          radiance = l.map->eval(wi);
        } else if (l.type == LightType::Environment) {
          d = -sample_uniform_sphere(u_dir);  // radiance arrives from -d: any direction
          dir_pdf = uniform_sphere_pdf();
        }
        const Vec2 disk = sample_uniform_disk_concentric(u_pos) * r;
        const Frame f(d);
        e.o = scene_center_ + (f.s * disk.x + f.t * disk.y) - d * r;
        e.d = d;
        // Directional: E * (pi r^2). Environment: L * (pi r^2) / pdf_dir.
        e.power = radiance * (kPi * r * r / (dir_pdf * pmf));
        emission_pdf(i, e.d, e.pdf_pos, e.pdf_dir);
        return e;
      }
    }
    return std::nullopt;
  });
}

}  // namespace gp
