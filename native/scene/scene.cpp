#include "scene/scene.h"

#include "core/parallel.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "scene/accel.h"
#include "scene/shapes.h"
#include "shading/hash.h"
#include "textures/normal_mapping.h"

namespace gp {

Scene::Scene() = default;
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

Vec3 offset_ray_origin(const Vec3& p, const Vec3& ng, const Vec3& w) {
  // Move p along the normal (on w's side) by a few ULPs in integer space, or by a small
  // fixed amount near the origin where ULPs are tiny (Wächter & Binder 2019).
  constexpr float kOrigin = 1.0f / 32.0f, kFloatScale = 1.0f / 65536.0f, kIntScale = 256.0f;
  const Vec3 n = dot(ng, w) < 0 ? -ng : ng;
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    const int of_i = static_cast<int>(kIntScale * n[i]);
    const float pi = p[i];
    int32_t bits;
    std::memcpy(&bits, &pi, 4);
    bits += (p[i] < 0) ? -of_i : of_i;
    float p_i;
    std::memcpy(&p_i, &bits, 4);
    out[i] = std::abs(p[i]) < kOrigin ? p[i] + kFloatScale * n[i] : p_i;
  }
  return out;
}

Ray scattered_ray(const Vec3& p, const Vec3& ng, const Vec3& wi, const Ray& in, bool pass_through, const BsdfSample& bs) {
  Ray next(offset_ray_origin(p, ng, wi), wi);
  if (pass_through) {
    next.camera = in.camera;
    next.bounce = in.bounce;
    next.state = in.state;
    next.state.length = 0.0f;
  } else if (is_transparent_pass(bs)) {
    // A Transparent BSDF's pass (a transparent bounce) keeps the ray's flags, as Cycles'
    // path_state_next: a camera ray stays one, its kind stays.
    next.camera = in.camera;
    next.bounce = in.bounce;
    next.state = next_ray_state(in.state, bs.lobe, bs.transmission, bs.delta, bs.eta);
  } else {
    next.bounce = bs.lobe;
    next.state = next_ray_state(in.state, bs.lobe, bs.transmission, bs.delta, bs.eta);
  }
  return next;
}

RayState next_ray_state(const RayState& in, uint8_t lobe, bool transmission, bool delta, float eta) {
  // Cycles' labels: a Transparent BSDF's pass (smooth, IOR 1) is LABEL_TRANSPARENT; a diffuse
  // lobe LABEL_DIFFUSE; a smooth one LABEL_SINGULAR; the rest glossy. (A Translucent BSDF's
  // diffuse transmission reads as glossy here: its sample carries only kRayTransmission.)
  const bool transparent = transmission && delta && eta == 1.0f;
  return in.next(transmission, lobe == kRayDiffuse, delta, transparent);
}

size_t Scene::triangle_count() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangle_count();
  return n;
}

void Scene::finalize() {
  build_lights();
  accel_ = std::make_unique<Accelerator>(meshes, &materials);
  changed_meshes_.clear();
  moved_meshes_.clear();
}


// A mesh's attributes must fit it: one element per vertex (point), triangle corner (corner) or
// triangle (face), 1-4 finite components, distinct names.
static void check_attributes(const shading::MeshAttributes& attrs, const Mesh& m, const std::string& where) {
  static const char* kDomain[] = {"point", "corner", "face"};
  for (size_t i = 0; i < attrs.list.size(); ++i) {
    const shading::MeshAttribute& a = attrs.list[i];
    const std::string at = fmt::format("{}: attribute '{}'", where, a.name);
    if (a.components < 1 || a.components > 4)
      throw std::runtime_error(fmt::format("{}: {} components (1 to 4)", at, a.components));
    const size_t want = a.domain == shading::AttributeDomain::Point    ? m.positions.size()
                        : a.domain == shading::AttributeDomain::Corner ? 3 * m.triangle_count()
                                                                       : m.triangle_count();
    if (a.values.size() != want * a.components)
      throw std::runtime_error(fmt::format("{}: {} values for {} {} elements of {} components", at, a.values.size(),
                                           want, kDomain[static_cast<int>(a.domain)], a.components));
    for (size_t k = 0; k < a.values.size(); ++k)
      if (!std::isfinite(a.values[k]))
        throw std::runtime_error(fmt::format("{}: element {} is not finite", at, k / a.components));
    for (size_t j = 0; j < i; ++j)
      if (attrs.list[j].name == a.name) throw std::runtime_error(fmt::format("{}: given twice", at));
  }
  if (attrs.default_color >= static_cast<int>(attrs.list.size()))
    throw std::runtime_error(fmt::format("{}: default colour attribute {} of {}", where, attrs.default_color,
                                         attrs.list.size()));
}

void Scene::build_shading_camera() { *shading_camera_ = make_shading_camera(camera); }

shading::ShadingCamera make_shading_camera(const Camera& camera) {
  shading::ShadingCamera c;
  // Cycles' camera space is Blender's camera space with z negated (z towards the view).
  c.camera_to_world = camera.camera_to_world;
  for (int r = 0; r < 3; ++r) c.camera_to_world.m[r][2] = -c.camera_to_world.m[r][2];
  c.world_to_camera = invert_affine(c.camera_to_world);
  c.orthographic = camera.projection == Projection::Orthographic;
  c.ext = camera.half_extent();
  const float s = 2.0f * std::max(c.ext.x, c.ext.y);  // as Camera::generate_ray's shift
  c.shift = Vec2(camera.shift.x * s, camera.shift.y * s);
  return c;
}

void Scene::build_shading_objects() {
  build_shading_camera();
  shading_objects_.assign(meshes.size(), {});
  for (size_t mi = 0; mi < meshes.size(); ++mi) {
    const Mesh& m = meshes[mi];
    shading::ShadingObject& o = shading_objects_[mi];
    o.to_world = m.to_world;
    o.to_object = invert_affine(m.to_world);
    // Object-space bounds (Blender's auto texture space of Generated coordinates).
    if (m.source) {
      for (const Vec3& p : m.source->positions) o.bounds.extend(p);
    } else {
      for (const Vec3& p : m.positions) o.bounds.extend(o.to_object.point(p));
    }
    // Object Info's Random (Cycles, blender/object.cpp): an instance's random id, else the hash
    // of the object's name (hash_uint2(hash_string(name), 0)), as a float in [0, 1].
    o.random = shading::uint_to_float_incl(
        m.random_id ? *m.random_id : shading::hash_uint2(shading::hash_string_x37(m.name.c_str()), 0u));
    if (m.attributes && !m.attributes->list.empty()) {
      o.attributes = m.attributes.get();
      o.indices = m.indices.data();
    }
  }
}

shading::ShadingContext Scene::shading_context(const SurfacePoint& h, const Vec3& wo, const Vec3& n_smooth) const {
  // Cycles' ShaderData: normals face the incoming ray, `backfacing` says whether they were flipped.
  // (Built in place, each field written once: no zero-fill of the whole context first.)
  const bool backfacing = dot(h.ng, wo) < 0;
  const Vec3 ng = backfacing ? -h.ng : h.ng;
  shading::ShadingContext c(h.p, dot(n_smooth, ng) < 0 ? -n_smooth : n_smooth, ng, wo, h.uv, h.bary,
                            shading_camera_.get(), backfacing);
  if (h.mesh >= 0) {
    const Mesh& m = meshes[h.mesh];
    // The tangents only where a graph reads them (Bump, Normal Map, Geometry's Tangent): the
    // triangle's corners and its uv Jacobian are a good part of a procedural hit's cost.
    if (h.material < 0 || materials[h.material].graph_reads_tangents()) {
      const uint32_t i0 = m.indices[3 * h.prim], i1 = m.indices[3 * h.prim + 1], i2 = m.indices[3 * h.prim + 2];
      const bool has_uvs = !m.uvs.empty();
      Vec3 v[3];
      triangle_at(h.mesh, h.prim, shutter_time(), v);  // the path's time (a moving mesh's tangents turn)
      if (!triangle_dpduv(v[0], v[1], v[2], has_uvs ? m.uvs[i0] : Vec2(0, 0),
                          has_uvs ? m.uvs[i1] : Vec2(1, 0), has_uvs ? m.uvs[i2] : Vec2(0, 1), &c.dPdu, &c.dPdv))
        c.dPdu = c.dPdv = Vec3(0.0f);
    }
    if (static_cast<size_t>(h.mesh) < shading_objects_.size()) {
      c.object = &shading_objects_[h.mesh];
      // A moving object's Object/Generated coordinates, Object Info and Vector Transform at the
      // path's time, so that its textures move with it (Cycles: shader_setup_object_transforms
      // at the ray's time, kernel/geom/shader_data.h).
      if (m.motion && !m.motion->transform.empty()) c.set_object_at(*c.object, m.motion->transform.at(shutter_time()));
    }
    c.prim = h.prim;
  }
  return c;
}

// A moving mesh's steps: counts, vertex counts and finite values (a Python caller may set them);
// the scene's bounds take in every step (distant lights' photons must cover the whole shutter).
void Scene::check_mesh_motion(const Mesh& m, const std::string& where) {
  const MeshMotion& mo = *m.motion;
  if (mo.transform.size() == 1)
    throw std::runtime_error(fmt::format("{}: motion has 1 transform (at least 2 are needed)", where));
  if (mo.positions.size() == 1)
    throw std::runtime_error(fmt::format("{}: motion_positions has 1 step (at least 2 are needed)", where));
  if (mo.object_positions.size() != m.positions.size())
    throw std::runtime_error(fmt::format("{}: {} object-space positions for {} vertices", where,
                                         mo.object_positions.size(), m.positions.size()));
  for (size_t s = 0; s < mo.positions.size(); ++s) {
    if (mo.positions[s].size() != m.positions.size())
      throw std::runtime_error(fmt::format("{}: motion_positions step {} has {} vertices, the mesh {}", where, s,
                                           mo.positions[s].size(), m.positions.size()));
    for (const Vec3& p : mo.positions[s])
      if (!is_finite(p)) throw std::runtime_error(fmt::format("{}: motion_positions step {} is not finite", where, s));
  }
  for (const DecomposedTransform& d : mo.transform.steps())
    if (!is_finite(d.translation) || !std::isfinite(d.s00 * d.s11 * d.s22) || !(d.s00 * d.s11 * d.s22 != 0) ||
        !std::isfinite(d.qr + d.qi + d.qj + d.qk))
      throw std::runtime_error(fmt::format("{}: a motion transform is not finite or is singular", where));
  const size_t steps = std::max<size_t>({2, 2 * mo.transform.size(), mo.positions.size()});
  for (size_t k = 0; k <= steps; ++k) {
    const float t = static_cast<float>(k) / static_cast<float>(steps);
    const Transform tw = mo.to_world_at(t);
    for (uint32_t v = 0; v < mo.object_positions.size(); ++v) bounds_.extend(tw.point(mo.object_vertex(v, t)));
  }
}

void Scene::build_lights() {
  build_shading_objects();
  bounds_ = Bounds3();
  std::vector<Light> all_lights = lights;
  bool moving = !camera.motion.empty();
  triangle_light_.assign(meshes.size(), {});
  for (size_t mi = 0; mi < meshes.size(); ++mi) {
    const Mesh& m = meshes[mi];
    const std::string where = fmt::format("{}: mesh '{}'", source, m.name);
    if (m.indices.size() % 3 != 0)
      throw std::runtime_error(fmt::format("{}: index count {} is not a multiple of 3", where, m.indices.size()));
    if (m.material_ids.size() != m.triangle_count())
      throw std::runtime_error(fmt::format("{}: {} material ids for {} triangles", where,
                                           m.material_ids.size(), m.triangle_count()));
    if (!m.normals.empty() && m.normals.size() != m.positions.size())
      throw std::runtime_error(fmt::format("{}: {} normals for {} positions", where, m.normals.size(), m.positions.size()));
    if (!m.uvs.empty() && m.uvs.size() != m.positions.size())
      throw std::runtime_error(fmt::format("{}: {} uvs for {} positions", where, m.uvs.size(), m.positions.size()));
    if (m.attributes) check_attributes(*m.attributes, m, where);
    for (size_t v = 0; v < m.positions.size(); ++v) {
      if (!is_finite(m.positions[v]))
        throw std::runtime_error(fmt::format("{}: vertex {} is not finite", where, v));
      bounds_.extend(m.positions[v]);
    }
    for (size_t k = 0; k < m.indices.size(); ++k)
      if (m.indices[k] >= m.positions.size())
        throw std::runtime_error(fmt::format("{}: triangle {} uses vertex {} but the mesh has {} vertices",
                                             where, k / 3, m.indices[k], m.positions.size()));
    if (m.motion) check_mesh_motion(m, where);
    if (m.motion) moving = true;
    triangle_light_[mi].assign(m.triangle_count(), -1);
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const uint32_t mat = m.material_ids[t];
      if (mat >= materials.size())
        throw std::runtime_error(fmt::format("{}: triangle {} has material index {} but there are {} materials",
                                             where, t, mat, materials.size()));
      const Vec3 &a = m.positions[m.indices[3 * t]], &b = m.positions[m.indices[3 * t + 1]],
                 &c = m.positions[m.indices[3 * t + 2]];
      const Vec3 nc = cross(b - a, c - a);
      const float area = 0.5f * length(nc);
      if (!(area > 0)) {
        warnings.add("zero-area triangle", fmt::format("{} triangle {}", where, t));
        continue;
      }
      const Material& mtl = materials[mat];
      if (mtl.is_emissive() || mtl.emission_from_graph()) {
        Light l;
        l.type = LightType::Area;
        l.name = fmt::format("{}#{}", m.name, t);
        l.emit = mtl.radiance();
        if (mtl.emission_from_graph()) {
          // Radiance from the node graph per point (EmissionGraph); emit: its average over the
          // triangle at 7 points, for light selection and as the light's power.
          auto g = std::make_shared<EmissionGraph>();
          g->program = mtl.graph;
          g->emission_linked = static_cast<bool>(mtl.emission_in);
          g->strength_linked = static_cast<bool>(mtl.strength_in);
          g->emission = mtl.emission_in.source;
          g->strength = mtl.strength_in.source;
          g->emission_constant = mtl.emission;
          g->strength_constant = mtl.emission_strength;
          g->object = &shading_objects_[mi];
          g->prim = static_cast<int>(t);
          g->camera = shading_camera_.get();
          const uint32_t* tri = &m.indices[3 * t];
          const bool has_uvs = !m.uvs.empty();
          g->uv0 = has_uvs ? m.uvs[tri[0]] : Vec2(0, 0);
          g->uv1 = has_uvs ? m.uvs[tri[1]] : Vec2(1, 0);
          g->uv2 = has_uvs ? m.uvs[tri[2]] : Vec2(0, 1);
          l.p0 = a; l.p1 = b; l.p2 = c;
          l.n = nc / (2.0f * area);
          static const float kB[7][2] = {{1 / 3.f, 1 / 3.f}, {2 / 3.f, 1 / 6.f}, {1 / 6.f, 2 / 3.f}, {1 / 6.f, 1 / 6.f},
                                         {0.5f, 0.5f}, {0.5f, 0.0f}, {0.0f, 0.5f}};
          RGB sum(0.0f);
          for (const auto& bb : kB) sum += g->at(l, a * (1 - bb[0] - bb[1]) + b * bb[0] + c * bb[1], l.n);
          l.emit = sum / 7.0f;
          l.emission_graph = std::move(g);
          if (l.emit.is_black()) l.emit = RGB(1e-6f);  // still sampled: the average can miss a pattern
        }
        l.p0 = a; l.p1 = b; l.p2 = c;
        l.n = nc / (2.0f * area);
        l.area = area;
        l.two_sided = mtl.two_sided;
        l.visible_lobes = mtl.visible_lobes;
        l.lines = mtl.emission_lines;
        l.line_fwhm = mtl.emission_fwhm;
        l.mesh = static_cast<int>(mi);
        l.prim = static_cast<int>(t);
        if (m.motion) {  // an emissive triangle moving with its mesh: sampled where it is at the path's time
          l.motion = m.motion;
          std::copy(&m.indices[3 * t], &m.indices[3 * t] + 3, l.tri);
        }
        triangle_light_[mi][t] = static_cast<int32_t>(all_lights.size());
        all_lights.push_back(l);
      }
    }
  }
  for (const Light& l : lights) {
    if (!l.emit.is_finite())
      throw std::runtime_error(fmt::format("{}: light '{}' has a non-finite value", source, l.name));
    if (l.lamp_motion) moving = true;  // a moving lamp: paths and passes draw a time
  }
  lights_hidden_from_some_lobes_ = std::any_of(all_lights.begin(), all_lights.end(),
                                               [](const Light& l) { return l.visible_lobes != kAllLobes; });
  surfaces_hidden_from_some_lobes_ = std::any_of(materials.begin(), materials.end(), [](const Material& m) {
    return m.visible_lobes != kAllLobes && !m.is_pass_through();
  });
  has_holdout_ = std::any_of(materials.begin(), materials.end(),
                             [](const Material& m) { return m.holdout || m.holds_out_partly(); });
  // Media: indices in range, coefficients finite and non-negative (a Python caller may set them).
  const auto check_medium = [&](int m, const std::string& who) {
    if (m < -1 || m >= static_cast<int>(media.size()))
      throw std::runtime_error(fmt::format("{}: {} names medium {} of {}", source, who, m, media.size()));
  };
  check_medium(world_medium, "the World");
  for (const Material& m : materials) check_medium(m.interior, fmt::format("material '{}'", m.name));
  for (const Medium& m : media)
    if (!m.sigma_a.is_finite() || !m.sigma_s.is_finite() || !m.emission.is_finite() || !std::isfinite(m.g) ||
        std::fmin(m.sigma_a.r, std::fmin(m.sigma_a.g, m.sigma_a.b)) < 0 ||
        std::fmin(m.sigma_s.r, std::fmin(m.sigma_s.g, m.sigma_s.b)) < 0 ||
        std::fmin(m.emission.r, std::fmin(m.emission.g, m.emission.b)) < 0)
      throw std::runtime_error(fmt::format("{}: medium '{}' has a negative or non-finite coefficient", source, m.name));
  has_media_ = world_medium >= 0 || std::any_of(materials.begin(), materials.end(),
                                                [](const Material& m) { return m.interior >= 0; });
  has_transparent_shadows_ =
      std::any_of(materials.begin(), materials.end(), [](const Material& m) { return m.transparent_shadow(); });
  if (transparent_bounces < 0)
    throw std::runtime_error(fmt::format("{}: transparent_bounces is {} (at least 0)", source, transparent_bounces));
  if (!(filter_glossy >= 0.0f && std::isfinite(filter_glossy)))
    throw std::runtime_error(fmt::format("{}: filter_glossy is {} (a finite number, at least 0)", source, filter_glossy));
  auto grid = [&](int m) { return m >= 0 && m < static_cast<int>(media.size()) && !media[m].is_homogeneous(); };
  has_grid_media_ = grid(world_medium) ||
                    std::any_of(materials.begin(), materials.end(), [&](const Material& m) { return grid(m.interior); });
  camera.motion_blur = moving;
  if (all_lights.empty()) warnings.add("no lights", fmt::format("{}: the scene has no light and will render black", source));
  light_set_ = LightSet(std::move(all_lights), bounds_);
}

// ---- Updates ----

Scene::RenderGuard::RenderGuard(const Scene& s) : s_(s) {
  int n = s_.state_->load();
  do {
    if (n < 0) throw std::logic_error(fmt::format("{}: cannot render while the scene is being updated", s_.source));
  } while (!s_.state_->compare_exchange_weak(n, n + 1));
}

Scene::UpdateGuard::UpdateGuard(Scene& s) : s_(s) {
  int idle = 0;
  if (!s_.state_->compare_exchange_strong(idle, -1))
    throw std::logic_error(fmt::format("{}: cannot update the scene while {}", s_.source,
                                       idle > 0 ? "a render uses it (cancel it first)" : "another update runs"));
}

void Scene::check_not_rendering(const char* what) const {
  if (rendering())
    throw std::logic_error(fmt::format("{}: cannot {} while a render uses the scene (cancel it first)", source, what));
}

std::string check_object_matrix(const Transform& t) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(t.m[r][c]))
        return fmt::format("the matrix is not finite (row {}, column {} is {})", r, c, t.m[r][c]);
  if (t.m[3][0] != 0 || t.m[3][1] != 0 || t.m[3][2] != 0 || t.m[3][3] != 1)
    return "the matrix is not affine (last row must be 0 0 0 1)";
  if (linear_determinant(t) == 0) return "the matrix is singular (zero scale?)";
  return {};
}

void set_mesh_motion(Mesh& mesh, const Transform& to_world, const std::vector<Transform>& transforms,
                     std::vector<std::vector<Vec3>> steps) {
  if (transforms.size() == 1)
    throw std::invalid_argument("'motion' has 1 transform: give at least 2 (shutter open and close)");
  if (steps.size() == 1)
    throw std::invalid_argument("'motion_positions' has 1 step: give at least 2 (shutter open and close)");
  if (const std::string bad = check_object_matrix(to_world); !bad.empty()) throw std::invalid_argument(bad);
  for (size_t i = 0; i < transforms.size(); ++i)
    if (const std::string bad = check_object_matrix(transforms[i]); !bad.empty())
      throw std::invalid_argument(fmt::format("motion transform {}: {}", i, bad));
  for (size_t s = 0; s < steps.size(); ++s) {
    if (steps[s].size() != mesh.positions.size())
      throw std::invalid_argument(fmt::format("motion_positions step {} has {} vertices, 'positions' {}", s,
                                              steps[s].size(), mesh.positions.size()));
    for (size_t v = 0; v < steps[s].size(); ++v)
      if (!is_finite(steps[s][v]))
        throw std::invalid_argument(fmt::format("motion_positions step {} vertex {} is not finite", s, v));
  }
  auto motion = std::make_shared<MeshMotion>();
  if (!transforms.empty()) {
    motion->transform = TransformMotion(transforms);
    if (motion->transform.still()) motion->transform = TransformMotion();  // "moves" nowhere: static
  }
  motion->to_world = to_world;
  motion->positions = std::move(steps);
  motion->object_positions = mesh.positions;
  motion->object_normals = mesh.normals;
  auto src = std::make_shared<MeshSource>();
  src->positions = mesh.positions;
  src->normals = mesh.normals;
  mesh.source = src;
  mesh.to_world = Transform();
  transform_mesh(*src, to_world, mesh);  // the frame's world-space arrays
  if (!motion->transform.empty() || !motion->positions.empty()) mesh.motion = std::move(motion);
}

void transform_mesh(const MeshSource& src, const Transform& tr, Mesh& m) {
  // Cofactor matrix of the 3x3 part = det * inverse transpose (for normals); the sign of det
  // is folded back in so the normals keep their side.
  const auto& a = tr.m;
  float nm[3][3] = {{a[1][1] * a[2][2] - a[1][2] * a[2][1], a[1][2] * a[2][0] - a[1][0] * a[2][2],
                     a[1][0] * a[2][1] - a[1][1] * a[2][0]},
                    {a[0][2] * a[2][1] - a[0][1] * a[2][2], a[0][0] * a[2][2] - a[0][2] * a[2][0],
                     a[0][1] * a[2][0] - a[0][0] * a[2][1]},
                    {a[0][1] * a[1][2] - a[0][2] * a[1][1], a[0][2] * a[1][0] - a[0][0] * a[1][2],
                     a[0][0] * a[1][1] - a[0][1] * a[1][0]}};
  const bool mirror = linear_determinant(tr) < 0;
  if (mirror)
    for (auto& row : nm)
      for (float& v : row) v = -v;
  const size_t nv = src.positions.size();
  const bool normals = !src.normals.empty();
  m.positions.resize(nv);
  m.normals.resize(normals ? nv : 0);
  parallel_for(nv, 0, [&](size_t begin, size_t end) {
    for (size_t v = begin; v != end; ++v) {
      m.positions[v] = tr.point(src.positions[v]);
      if (normals) {
        const Vec3& n = src.normals[v];
        const Vec3 w{nm[0][0] * n.x + nm[0][1] * n.y + nm[0][2] * n.z, nm[1][0] * n.x + nm[1][1] * n.y + nm[1][2] * n.z,
                     nm[2][0] * n.x + nm[2][1] * n.y + nm[2][2] * n.z};
        const float len = length(w);
        m.normals[v] = len > 0 && std::isfinite(len) ? w / len : Vec3(0, 0, 1);
      }
    }
  });
  // A mirroring matrix reverses the winding so geometric normals keep their side (as the
  // loader); the indices hold the previous matrix's winding, so swap when the sign changes.
  if (mirror != (linear_determinant(m.to_world) < 0))
    for (size_t k = 0; k + 2 < m.indices.size(); k += 3) std::swap(m.indices[k + 1], m.indices[k + 2]);
  m.to_world = tr;
}

void Scene::set_mesh_transform(size_t index, const Transform& to_world) {
  check_not_rendering("move an object");
  if (index >= meshes.size())
    throw std::invalid_argument(fmt::format("{}: no mesh {} (the scene has {})", source, index, meshes.size()));
  Mesh& m = meshes[index];
  if (!m.source)
    throw std::invalid_argument(fmt::format("{}: mesh '{}' comes from a scene file and cannot be moved", source, m.name));
  if (const std::string bad = check_object_matrix(to_world); !bad.empty())
    throw std::invalid_argument(fmt::format("{}: object '{}': {}", source, m.name, bad));
  if (m.motion) {
    // The viewport moves objects without blur (as Cycles' viewport): a moving mesh becomes
    // a still one at its new place (its geometry rebuilt without time steps).
    m.motion.reset();
    changed_meshes_.push_back(index);
  } else if (std::memcmp(&to_world, &m.to_world, sizeof(Transform)) == 0) {
    return;  // not moved: stays flat
  }
  transform_mesh(*m.source, to_world, m);  // world-space arrays: lights, photon chains, manifold walks
  moved_meshes_.push_back(index);
}

void Scene::set_camera(const Camera& cam) {
  check_not_rendering("move the camera");
  if (const std::string bad = cam.check(); !bad.empty()) throw std::invalid_argument(fmt::format("{}: {}", source, bad));
  camera = cam;
  build_shading_camera();
  ++generation_;
}

void Scene::mark_mesh_changed(size_t index) {
  check_not_rendering("change an object");
  if (index >= meshes.size())
    throw std::invalid_argument(fmt::format("{}: no mesh {} (the scene has {})", source, index, meshes.size()));
  changed_meshes_.push_back(index);
}

void Scene::commit() {
  check_not_rendering("update the scene");
  if (!accel_) throw std::logic_error("Scene::commit before finalize");
  build_lights();
  for (auto* list : {&changed_meshes_, &moved_meshes_}) {
    std::sort(list->begin(), list->end());
    list->erase(std::unique(list->begin(), list->end()), list->end());
  }
  for (size_t i : changed_meshes_) accel_->replace_mesh(i, meshes[i], &materials);
  for (size_t i : moved_meshes_) accel_->move_mesh(i, meshes[i], &materials);
  if (!changed_meshes_.empty() || !moved_meshes_.empty()) accel_->commit();
  changed_meshes_.clear();
  moved_meshes_.clear();
  ++generation_;
}

std::optional<SurfaceHit> Scene::intersect(const Ray& ray) const {
  RawHit raw;
  if (!accel_->intersect(ray, raw)) return std::nullopt;
  return surface_hit(raw, ray);
}

std::optional<SurfacePoint> Scene::intersect_point(const Ray& ray) const {
  RawHit raw;
  if (!accel_->intersect(ray, raw)) return std::nullopt;
  std::optional<SurfacePoint> out(std::in_place);
  surface_point(raw, *out);
  return out;
}

void Scene::intersect_coherent(const Ray* rays, size_t n, std::optional<SurfaceHit>* hits) const {
  thread_local std::vector<RawHit> raw;
  thread_local std::unique_ptr<bool[]> found;  // (vector<bool> has no bool array to write into)
  thread_local size_t capacity = 0;
  raw.resize(n);
  if (capacity < n) {
    found.reset(new bool[n]);
    capacity = n;
  }
  accel_->intersect_stream(rays, n, raw.data(), found.get(), true);
  for (size_t i = 0; i < n; ++i) {
    if (found[i]) hits[i] = surface_hit(raw[i], rays[i]);
    else hits[i].reset();
  }
}

void trace_camera_rays(const Scene& scene, const PixelStart* starts, size_t n, Ray* rays,
                       std::optional<SurfaceHit>* hits) {
  const Vec2 ext = scene.camera.half_extent();  // a tan: once, not per ray
  for (size_t i = 0; i < n; ++i) rays[i] = scene.camera.generate_ray(starts[i].film, starts[i].lens, ext, starts[i].time);
  scene.intersect_coherent(rays, n, hits);
}

void hold_out_camera_rays(const Scene& scene, size_t n, Ray* rays, std::optional<SurfaceHit>* hits, float* coverage) {
  // Cycles ends a camera path at a holdout with its throughput as transparency
  // (integrator/shade_surface.h, integrate_surface_holdout): no colour, alpha 0. A holdout
  // weighted in a mix adds weight x throughput (1 at the camera's first hit) to the
  // transparency and the path goes on with the other closures (shader_holdout_apply).
  for (size_t i = 0; i < n; ++i) {
    if (!hits[i]) continue;
    const Material& m = scene.material(hits[i]->material);
    if (m.holdout) {
      hits[i].reset();
      rays[i].held_out = true;
    } else if (coverage && m.holds_out_partly()) {
      float w = m.holdout_weight;
      if (m.holdout_in && m.graph) {
        const ShutterTime at_time(rays[i].time);  // a moving mesh's shading frame at the ray's time
        const SurfaceHit& h = *hits[i];
        thread_local std::vector<Vec3> regs;
        regs.resize(m.graph->num_registers());
        m.graph->run(scene.shading_context(h, h.wo, h.n_smooth), regs.data());
        w = shading::as_float(regs[m.holdout_in.source.reg], m.holdout_in.source.conv);
      }
      coverage[i] = std::isfinite(w) ? 1.0f - std::clamp(w, 0.0f, 1.0f) : 1.0f;
    }
  }
}

void Scene::surface_point(const RawHit& raw, SurfacePoint& h) const {
  const Mesh& m = meshes[raw.geom];
  const uint32_t i0 = m.indices[3 * raw.prim], i1 = m.indices[3 * raw.prim + 1], i2 = m.indices[3 * raw.prim + 2];
  const float b1 = raw.u, b2 = raw.v, b0 = 1.0f - b1 - b2;
  h.t = raw.t;
  // A moving mesh: the triangle where it was at the ray's time (the same interpolation as the
  // accelerator's), so position, normal and tangents are those of the surface the ray met.
  Vec3 moved[3];
  const Vec3* v[3] = {&m.positions[i0], &m.positions[i1], &m.positions[i2]};
  if (m.motion) {
    m.motion->triangle(&m.indices[3 * raw.prim], raw.time, moved);
    v[0] = &moved[0], v[1] = &moved[1], v[2] = &moved[2];
  }
  // Interpolating the vertices is more precise than o + t d far from the ray origin.
  h.p = *v[0] * b0 + *v[1] * b1 + *v[2] * b2;
  h.ng = normalize(cross(*v[1] - *v[0], *v[2] - *v[0]));
  if (!m.uvs.empty()) h.uv = m.uvs[i0] * b0 + m.uvs[i1] * b1 + m.uvs[i2] * b2;
  else h.uv = Vec2(b1, b2);
  h.bary = Vec2(b1, b2);
  h.material = static_cast<int>(m.material_ids[raw.prim]);
  h.mesh = raw.geom;
  h.prim = raw.prim;
}

std::vector<PixelStart> tile_pixel_starts(const Camera& camera, uint64_t seed, uint64_t pass, const Tile& tile) {
  std::vector<PixelStart> starts;
  starts.reserve(static_cast<size_t>(tile.x1 - tile.x0) * (tile.y1 - tile.y0));
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; ++x) starts.push_back(start_pixel_in_pass(camera, seed, pass, x, y));
  return starts;
}

std::optional<SurfaceHit> Scene::surface_hit(const RawHit& raw, const Ray& ray) const {
  const Vec3& ray_dir = ray.d;
  const Mesh& m = meshes[raw.geom];
  const uint32_t i0 = m.indices[3 * raw.prim], i1 = m.indices[3 * raw.prim + 1], i2 = m.indices[3 * raw.prim + 2];
  const float b1 = raw.u, b2 = raw.v, b0 = 1.0f - b1 - b2;
  // Built in place in the returned optional (no copy of the record on every ray).
  std::optional<SurfaceHit> out(std::in_place);
  SurfaceHit& h = *out;
  surface_point(raw, h);
  h.ns = h.ng;
  if (!m.normals.empty()) {
    Vec3 n = m.normals[i0] * b0 + m.normals[i1] * b1 + m.normals[i2] * b2;
    // A moving object's normals turn with it (object-space normals under its transform at t).
    if (m.motion && !m.motion->transform.empty() && !m.motion->object_normals.empty()) {
      const auto& on = m.motion->object_normals;
      n = m.motion->transform.at(raw.time).normal(on[i0] * b0 + on[i1] * b1 + on[i2] * b2);
    }
    const float len = length(n);
    if (len > 0 && std::isfinite(len)) h.ns = n / len;
    if (dot(h.ns, h.ng) < 0) h.ns = -h.ns;  // shading normal on the geometric side
  }
  h.n_smooth = h.ns;
  h.wo = -ray_dir;
  h.ray = ray.state;
  h.ray.length = h.t;  // Cycles' sd->ray_length: the ray's (unit direction) distance to here
  if (const Material& mat = materials[h.material]; mat.perturbs_normal()) {
    // ---- Normal and bump maps: the shading normal of every method ----
    Vec3 dpdu, dpdv, v[3];
    triangle_at(raw.geom, raw.prim, raw.time, v);
    const bool has_uvs = !m.uvs.empty();
    if (triangle_dpduv(v[0], v[1], v[2], has_uvs ? m.uvs[i0] : Vec2(0, 0),
                       has_uvs ? m.uvs[i1] : Vec2(1, 0), has_uvs ? m.uvs[i2] : Vec2(0, 1), &dpdu, &dpdv)) {
      Vec3 n = h.ns;
      if (mat.normal_tex) n = normal_mapped(mat.normal_tex, mat.normal_strength, h.uv, n, dpdu, dpdv);
      if (mat.bump_tex) n = bump_mapped(mat.bump_tex, mat.bump_strength, mat.bump_distance, h.uv, n, dpdu, dpdv);
      if (mat.normal_in) {
        // A Normal Map or Bump node's output from the material's graph (world space, facing
        // the viewer as Cycles' normals do; back on the geometric side below).
        const Vec3 g = mat.graph->evaluate(shading_context(h), mat.normal_in.source);
        if (is_finite(g) && length_squared(g) > 0) n = normalize(g);
      }
      if (dot(n, h.ng) < 0) n = -n;  // stays on the geometric side
      h.ns = valid_reflection_normal(h.ng, -ray_dir, n);
    }
  }
  h.frame = Frame(h.ns);
  if (const Material* a = materials[h.material].anisotropic_part()) h.frame = tangent_frame(*a, h);
  h.light = triangle_light_[raw.geom][raw.prim];
  return out;
}

// An anisotropic material's shading frame: its first axis the tangent Cycles 3.4 gives the lobe
// (svm_closure.h): the linked Tangent, else the default of ShaderGraph::default_inputs (a
// Tangent node, radial about the object's Z axis: the Geometry node's Tangent output), turned by
// rotation x 2 pi about the normal (rotate_around_axis), projected into the shading plane.
// Where it degenerates (along the normal, on the axis) the plain frame stays.
Frame Scene::tangent_frame(const Material& a, const SurfaceHit& h) const {
  const shading::ShadingContext ctx = shading_context(h);
  Vec3 t(0.0f);
  if (a.tangent_in && a.graph) {
    t = a.graph->evaluate(ctx, a.tangent_in.source);
  } else if (ctx.object) {
    const Vec3 o = ctx.object->to_object.point(ctx.P);
    // Generated coordinates: the point in the object's bounds, 0 on a flat axis (as the node).
    Vec3 g = o;
    if (!ctx.object->bounds.empty()) {
      const Vec3 d = ctx.object->bounds.diagonal(), q = o - ctx.object->bounds.lo;
      g = Vec3(d.x != 0 ? q.x / d.x : 0.0f, d.y != 0 ? q.y / d.y : 0.0f, d.z != 0 ? q.z / d.z : 0.0f);
    }
    t = ctx.object->to_world.vector(Vec3(-(g.y - 0.5f), g.x - 0.5f, 0.0f));
  }
  float rotation = a.rotation;
  if (a.rotation_in && a.graph) rotation = shading::as_float(a.graph->evaluate(ctx, a.rotation_in.source), a.rotation_in.source.conv);
  Vec3 s = t - h.ns * dot(t, h.ns);
  if (!is_finite(s) || !(length_squared(s) > 1e-12f)) return h.frame;
  s = normalize(s);
  if (rotation != 0.0f && std::isfinite(rotation)) {
    const float phi = rotation * 2.0f * kPi;  // Rodrigues about ns (s is perpendicular to it)
    s = s * std::cos(phi) + cross(h.ns, s) * std::sin(phi);
  }
  Frame f;
  f.n = h.ns;
  f.s = s;
  f.t = cross(h.ns, s);
  return f;
}

void Scene::triangle_at(int mesh, int prim, float time, Vec3 out[3]) const {
  const Mesh& m = meshes[mesh];
  const uint32_t* tri = &m.indices[3 * static_cast<size_t>(prim)];
  if (m.motion) return m.motion->triangle(tri, time, out);
  for (int k = 0; k < 3; ++k) out[k] = m.positions[tri[k]];
}

float Scene::pass_shutter_time(uint64_t seed, uint64_t pass) const {
  if (!has_motion()) return 0.0f;
  // A stream no pixel or photon uses (their keys are pixel and photon indices below 2^63).
  return Rng::for_key(seed, ~uint64_t{0}, pass).uniform();
}

SurfacePoint Scene::point_at(int mesh, int prim, const Vec3& p) const {
  const Mesh& m = meshes[mesh];
  const uint32_t i0 = m.indices[3 * prim], i1 = m.indices[3 * prim + 1], i2 = m.indices[3 * prim + 2];
  SurfacePoint sp;
  sp.p = p;
  sp.mesh = mesh;
  sp.prim = prim;
  sp.material = static_cast<int>(m.material_ids[prim]);
  Vec3 v[3];
  triangle_at(mesh, prim, shutter_time(), v);  // where the triangle is at the thread's time
  // Barycentrics of p's projection onto the triangle's plane.
  const Vec3 e1 = v[1] - v[0], e2 = v[2] - v[0], d = p - v[0];
  sp.ng = normalize(cross(e1, e2));
  const float d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2), dp1 = dot(d, e1), dp2 = dot(d, e2);
  const float det = d11 * d22 - d12 * d12;
  if (!(std::abs(det) > 0)) {
    sp.uv = m.uvs.empty() ? Vec2() : m.uvs[i0];
    return sp;
  }
  const float b1 = (d22 * dp1 - d12 * dp2) / det, b2 = (d11 * dp2 - d12 * dp1) / det;
  sp.bary = Vec2(b1, b2);
  sp.uv = m.uvs.empty() ? Vec2(b1, b2) : m.uvs[i0] * (1 - b1 - b2) + m.uvs[i1] * b1 + m.uvs[i2] * b2;  // as intersect()
  return sp;
}

bool Scene::occluded(const Ray& ray) const { return accel_->occluded(ray); }

bool Scene::occluded_between(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1) const {
  const Vec3 o = offset_ray_origin(p0, n0, p1 - p0);
  const Vec3 e = offset_ray_origin(p1, n1, p0 - p1);
  const Vec3 d = e - o;
  // Unnormalised direction: the segment is t in (0, 1); stop just short of the end point.
  return accel_->occluded(Ray(o, d, 0.0f, 1.0f - 1e-4f));
}

bool Scene::hides_between(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1, uint8_t kind) const {
  if (!surfaces_hidden_from_some_lobes_) return occluded_between(p0, n0, p1, n1);
  const Vec3 o = offset_ray_origin(p0, n0, p1 - p0);
  const Vec3 e = offset_ray_origin(p1, n1, p0 - p1);
  Ray ray(o, e - o, 0.0f, 1.0f - 1e-4f);
  ray.bounce = kind;
  RawHit raw;
  return accel_->intersect(ray, raw);
}

bool Scene::occluded(const Vec3& p, const Vec3& ng, const LightSample& ls) const {
  return accel_->occluded(shadow_ray(p, ng, ls));
}

Ray Scene::shadow_ray(const Vec3& p, const Vec3& ng, const LightSample& ls) const {
  if (ls.light >= 0 && light_set_.lights()[ls.light].type == LightType::Area) {
    // As occluded_between: both ends pushed off, the segment t in (0, 1) short of its end.
    const Vec3 o = offset_ray_origin(p, ng, ls.p - p);
    const Vec3 e = offset_ray_origin(ls.p, ls.n, p - ls.p);
    return Ray(o, e - o, 0.0f, 1.0f - 1e-4f);
  }
  const float tmax = std::isinf(ls.dist) ? kInfinity : ls.dist * (1.0f - 1e-4f);
  return Ray(offset_ray_origin(p, ng, ls.wi), ls.wi, 0.0f, tmax);
}

bool Scene::occluded_opaque(const Ray& ray, bool* crossed) const { return accel_->occluded_opaque(ray, crossed); }

std::optional<SurfaceHit> Scene::shadow_hit(const Ray& ray) const {
  RawHit raw;
  if (!accel_->intersect_shadow(ray, raw)) return std::nullopt;
  std::optional<SurfaceHit> h = surface_hit(raw, ray);
  h->ray.flags = kPathShadow;  // Cycles shades a shadow ray's surfaces with PATH_RAY_SHADOW (shade_shadow.h)
  return h;
}

}  // namespace gp
