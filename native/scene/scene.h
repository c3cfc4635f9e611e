// Scene: triangle meshes, the closed material set, lights and the camera, plus the
// acceleration structure built by finalize(). Integrators see only these types; Embree stays
// behind scene/accel.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/frame.h"
#include "core/log.h"
#include "core/math.h"
#include "core/motion.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "lights/light.h"
#include "materials/bsdf.h"
#include "materials/material.h"
#include "media/medium.h"
#include "scene/camera.h"

namespace gp {

class Accelerator;
struct RawHit;

// A mesh's arrays in object space (SceneBuilder keeps them, shared by its instances), so a moved
// object is transformed again from them without its arrays being sent again.
struct MeshSource {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  // empty = flat
};

struct Mesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;           // optional per-vertex shading normals (empty = flat)
  std::vector<Vec2> uvs;               // optional per-vertex UVs
  std::vector<uint32_t> indices;       // 3 per triangle
  std::vector<uint32_t> material_ids;  // 1 per triangle, index into Scene::materials
  // Named attributes (colour attributes, generic ones) for Color Attribute / Attribute nodes;
  // shared by the copies of an instanced mesh. Null: none.
  std::shared_ptr<const shading::MeshAttributes> attributes;
  // Object Info's Random as Cycles sets it (blender/object.cpp): an instance's own random id
  // (Blender's DepsgraphObjectInstance.random_id); unset, the hash of the object's name.
  std::optional<uint32_t> random_id;
  size_t triangle_count() const { return indices.size() / 3; }
  // Object space and object-to-world matrix of a mesh given as arrays (null for meshes of scene
  // files, which cannot be moved by Scene::set_mesh_transform).
  std::shared_ptr<const MeshSource> source;
  Transform to_world;
  // Motion blur (scene-format "Motion blur"): the mesh over the shutter, or null for a mesh that
  // does not move. `positions`, `normals` and `to_world` stay the frame's (what anything without
  // a time reads); hits, area lights and the accelerator use this at the ray's time.
  std::shared_ptr<const MeshMotion> motion;
};

// positions and normals of `mesh` = `source` under `to_world` (normals by the inverse transpose,
// renormalised); with a mirroring matrix the winding of `mesh.indices` is kept on the geometric
// normal's side (it is reversed when the sign of the determinant changes). Sets mesh.to_world.
void transform_mesh(const MeshSource& source, const Transform& to_world, Mesh& mesh);
// Empty, or why `t` cannot place an object: not finite, not affine, singular.
std::string check_object_matrix(const Transform& t);
// Motion blur: makes `mesh`, whose positions, normals and indices are still in object space,
// a mesh over the shutter placed at the frame's `to_world` (positions and normals moved there,
// winding kept for a mirroring matrix, as apply_transform): object motion `transforms` (S >= 2
// object-to-world matrices at evenly spaced shutter times; empty, or all equal: `to_world`
// throughout) and deformation `steps` (S' >= 2 object-space vertex arrays of the mesh's vertex
// count; empty: none). Keeps the object-space arrays (Mesh::source), so the viewport can move
// it. Throws std::invalid_argument saying what is wrong (the caller names the object).
void set_mesh_motion(Mesh& mesh, const Transform& to_world, const std::vector<Transform>& transforms,
                     std::vector<std::vector<Vec3>> steps);

// A ray's closest hit without what only shading needs (the interpolated shading normal, its
// frame, the light): for rays whose hit is only a place on a surface (a manifold walk's
// projections, GPM's photon-shift and reversibility rays). p, ng and uv are SurfaceHit's, bit
// for bit.
struct SurfacePoint {
  float t = kInfinity;
  Vec3 p;
  Vec3 ng;  // unit geometric normal (triangle winding)
  Vec2 uv;
  Vec2 bary;  // barycentric (u, v) in the triangle
  int mesh = -1, prim = -1;
  int material = -1;
};

// A ray's closest hit with everything shading needs.
struct SurfaceHit : SurfacePoint {
  Vec3 ns;        // unit shading normal, on the same side as ng
  Vec3 n_smooth;  // the interpolated normal before normal/bump maps (Cycles' sd->N)
  Frame frame;    // shading frame around ns
  int light = -1; // area light index of this triangle, or -1
  Vec3 wo;        // unit direction back along the ray that found it (node graphs' Incoming)
  RayState ray;   // that ray's Light Path state (Ray::state), with the length it travelled
};

// Where a measurement point lies, for its material's node graph: the hit's texture coordinate
// and triangle (position and normals are kept beside it). Integrators that shade a point after
// its ray is gone keep one (Scene::bsdf); a bare uv converts to one without a triangle.
struct ShadePoint {
  Vec2 uv, bary;
  int mesh = -1, prim = -1;
  ShadePoint() = default;
  ShadePoint(Vec2 uv_) : uv(uv_) {}  // NOLINT: uv-only callers
  explicit ShadePoint(const SurfacePoint& h) : uv(h.uv), bary(h.bary), mesh(h.mesh), prim(h.prim) {}
  operator Vec2() const { return uv; }  // NOLINT: where only the texture coordinate is read
};

// The camera rays of n pixels (their PixelStart: film position and lens sample) and their
// closest hits, traced together (Scene::intersect_coherent): what a tile's paths start from.
class Scene;
void trace_camera_rays(const Scene& scene, const PixelStart* starts, size_t n, Ray* rays,
                       std::optional<SurfaceHit>* hits);
// Camera rays whose closest hit is a holdout surface (Material::holdout) lose the hit and are
// marked Ray::held_out: their paths see neither the surface nor the background behind it. A hit
// on a surface held out by a weight (Material::holds_out_partly) stays, and `coverage` (n values,
// or null) gets 1 - weight there, 1 elsewhere: what the pixel's alpha takes from that sample.
void hold_out_camera_rays(const Scene& scene, size_t n, Ray* rays, std::optional<SurfaceHit>* hits,
                          float* coverage = nullptr);
// The same, held: n pixels' camera rays and closest hits, holdouts applied. The paths of the
// methods that start from here honour Holdout (Method::holdout).
struct CameraRays {
  std::vector<Ray> rays;
  std::vector<std::optional<SurfaceHit>> hits;
  // Each sample's share of its pixel's alpha before the path's own (0 when it escapes to a
  // transparent film or is held out whole): 1 - the holdout weight of a Holdout in a mix.
  std::vector<float> coverage;
  CameraRays(const Scene& scene, const PixelStart* starts, size_t n) : rays(n), hits(n), coverage(n, 1.0f) {
    trace_camera_rays(scene, starts, n, rays.data(), hits.data());
    hold_out_camera_rays(scene, n, rays.data(), hits.data(), coverage.data());
  }
};
// The camera as shading sees it (Texture Coordinate's Camera and Window; the World graph's copy).
shading::ShadingCamera make_shading_camera(const Camera& camera);
// The pixels of `tile`, row by row, started for `pass` (start_pixel_in_pass: the photon methods',
// whose camera rays take their pass's shutter time): what its camera rays need.
std::vector<PixelStart> tile_pixel_starts(const Camera& camera, uint64_t seed, uint64_t pass, const Tile& tile);

// Ray origin pushed off a surface so the next ray does not re-hit it ("A Fast and Robust
// Method for Avoiding Self-Intersection", Wächter & Binder, Ray Tracing Gems ch. 6).
Vec3 offset_ray_origin(const Vec3& p, const Vec3& ng, const Vec3& w);

// The ray a camera path sends on from a surface point p (geometric normal ng) along wi after a
// BSDF sample of kind `lobe`, `in` the ray that arrived: a light object (`pass_through`) lets
// `in` go on as it was (camera flag and kind kept); any other surface makes it a bounce ray of
// the sampled kind, which surfaces hidden from that kind let through (Ray::bounce). Its Light
// Path state (Ray::state) follows Cycles: kept through a light object, advanced by the sample
// otherwise.
Ray scattered_ray(const Vec3& p, const Vec3& ng, const Vec3& wi, const Ray& in, bool pass_through, const BsdfSample& bs);
// A ray's Light Path state after a BSDF sample of kind `lobe` (RayState::next; a smooth
// transmission of relative IOR 1 is Cycles' transparent bounce).
RayState next_ray_state(const RayState& in, uint8_t lobe, bool transmission, bool delta, float eta);

class Scene {
 public:
  Scene();
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Light> lights;  // non-area lights from the scene description
  // Participating media (media/medium.h): inside the meshes whose material names one as its
  // interior (Material::interior), and the World's (-1: none).
  std::vector<Medium> media;
  int world_medium = -1;
  // Light Paths > Volume bounces: scattering events in media a path may have beyond the first
  // (0: single scattering; -1: no limit but the method's bounces), camera_path.h.
  int volume_bounces = -1;
  // Light Paths > Max Bounces > Transparent (Cycles' transparent_max_bounce, 8 by default): a
  // shadow ray passes at most max(transparent_bounces - the path's transparent bounces - 1, 0)
  // transparent surfaces (intersect_shadow.h, integrate_shadow_max_transparent_hits); beyond,
  // it is blocked (paths/medium_walk.h ShadowTest).
  int transparent_bounces = 8;
  // Light Paths > Caustics (Cycles 3.4's path regularisation), honoured by the camera paths of
  // pt, spt and spt-hero (paths/camera_path.h): Filter Glossy (0: off; Blender's default 1.0)
  // raises the microfacet roughness of closures a path reaches after unlikely bounces, and the
  // Reflective / Refractive switches off drop glossy / transmission closures a diffuse bounce's
  // ray meets. A plain scene file filters nothing (docs/scene-format.md).
  float filter_glossy = 0.0f;
  bool caustics_reflective = true, caustics_refractive = true;
  bool filters_caustics() const { return filter_glossy > 0.0f || !caustics_reflective || !caustics_refractive; }
  Camera camera;
  std::string source;         // file the scene came from (for messages)
  Warnings warnings;          // counted load warnings

  // Validates, builds area lights from emissive triangles, the light distribution and the
  // accelerator. Throws std::runtime_error naming the object at fault.
  void finalize();
  bool finalized() const { return accel_ != nullptr; }

  // ---- Updates of a finalized scene (the rendered viewport, persistent data) ----
  // An update changes what renders see: it throws std::logic_error while a render holds the
  // scene (RenderGuard), and each committed update advances generation(), by which a render
  // made before it (an integrator holds what it derived from the scene) knows it is stale.
  //
  // Moves mesh `index` (which must have a source: built from arrays) to `to_world`; takes effect
  // at commit(). Throws std::invalid_argument for a bad index or matrix.
  void set_mesh_transform(size_t index, const Transform& to_world);
  // Replaces the camera (Camera::check'ed: std::invalid_argument); needs no commit().
  void set_camera(const Camera& camera);
  // Marks mesh `index` changed in ways commit() must pass on (its materials' ray visibility).
  void mark_mesh_changed(size_t index);
  // Rebuilds what depends on meshes, materials and lights: the area lights, the light
  // distribution and bounds, and the accelerator's changed meshes: a moved mesh is traced through
  // an instance of its own object-space BVH from its first move on, so a later move rebuilds only
  // the top level over a few instances (Accelerator::move_mesh); a scene never moved keeps one
  // flat BVH. Advances generation().
  void commit();
  uint64_t generation() const { return generation_; }

  // Held by a render while it reads the scene (any number at once); an UpdateGuard excludes
  // them. Each throws std::logic_error when the other is held: callers on several threads (the
  // Python module) see a clear error, never a race.
  class RenderGuard {
   public:
    explicit RenderGuard(const Scene& s);
    ~RenderGuard() { s_.state_->fetch_sub(1); }
    RenderGuard(const RenderGuard&) = delete;
    RenderGuard& operator=(const RenderGuard&) = delete;

   private:
    const Scene& s_;
  };
  class UpdateGuard {
   public:
    explicit UpdateGuard(Scene& s);
    ~UpdateGuard() { s_.state_->store(0); }
    UpdateGuard(const UpdateGuard&) = delete;
    UpdateGuard& operator=(const UpdateGuard&) = delete;

   private:
    Scene& s_;
  };
  bool rendering() const { return state_->load() > 0; }
  // Throws std::logic_error naming `what` while a render holds the scene.
  void check_not_rendering(const char* what) const;

  std::optional<SurfaceHit> intersect(const Ray& ray) const;
  // The same closest hit as intersect(), as a SurfacePoint (cheaper: no shading frame).
  std::optional<SurfacePoint> intersect_point(const Ray& ray) const;
  // hits[i] = intersect(rays[i]) for n rays that start close together in similar directions
  // (one tile's camera rays): Embree traces them as packets, several times faster than one by
  // one on this project's scenes, with the same answers (`gradphoton bench` checks that).
  void intersect_coherent(const Ray* rays, size_t n, std::optional<SurfaceHit>* hits) const;
  bool occluded(const Ray& ray) const;
  // Shadow ray between two surface points, both pushed off their surfaces.
  bool occluded_between(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1) const;
  // Whether a bounce ray of kind `kind` (Ray::bounce) from p0 towards p1 meets a surface before
  // p1: the segments the gradient methods' shifts reconnect, which must see what the base's ray
  // of that kind would (surfaces hidden from it let it through). As occluded_between where no
  // surface is hidden from any kind.
  bool hides_between(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1, uint8_t kind) const;
  // Shadow ray from surface point p (geometric normal ng) to a light sample: to its point for
  // area lights, else along wi up to just short of the light (or to infinity).
  bool occluded(const Vec3& p, const Vec3& ng, const LightSample& ls) const;
  // The ray occluded(p, ng, ls) traces.
  Ray shadow_ray(const Vec3& p, const Vec3& ng, const LightSample& ls) const;
  // Cycles' transparent shadows, for ShadowTest (paths/medium_walk.h): whether a surface that is
  // not transparent to shadows blocks `ray` (*crossed: it met a transparent one), and the
  // closest surface a shadow ray meets (those casting no shadow let through), shaded as a
  // shadow ray sees it (Light Path: Is Shadow Ray).
  bool occluded_opaque(const Ray& ray, bool* crossed) const;
  std::optional<SurfaceHit> shadow_hit(const Ray& ray) const;
  // True when some material that casts shadows has a Transparent BSDF (Material::
  // transparent_shadow; set by finalize() and commit()): only then do shadow rays look for them.
  bool has_transparent_shadows() const { return has_transparent_shadows_; }

  const LightSet& light_set() const { return light_set_; }
  // True when some light (or emissive surface) is hidden from some kind of bounce ray
  // (Light::visible_lobes): the path tracer then weighs its hits by the lobes that see it.
  bool lights_hidden_from_some_lobes() const { return lights_hidden_from_some_lobes_; }
  // True when some surface is hidden from some kind of bounce ray (Material::visible_lobes).
  bool surfaces_hidden_from_some_lobes() const { return surfaces_hidden_from_some_lobes_; }
  // True when some material has an interior medium or the World has one (set by finalize()
  // and commit()): the path tracers then track media; without, they run as before, bit for bit.
  bool has_media() const { return has_media_; }
  // True when some material holds out, wholly or weighted in a mix (Material::holdout,
  // holds_out_partly; set by finalize() and commit()): the methods that honour Holdout then
  // write pass alpha with an opaque film too (writes_alpha, integrators/integrator.h).
  bool has_holdout() const { return has_holdout_; }
  // Whether a medium in use is heterogeneous (grid, OpenVDB): the photon methods leave media
  // out then (SceneFeatures::grid_media says who renders them).
  bool has_grid_media() const { return has_grid_media_; }
  // True when some mesh or the camera moves over the shutter (set by finalize() and commit()):
  // paths then carry a shutter time (Ray::time); without, none is drawn and images are as before.
  bool has_motion() const { return camera.motion_blur; }
  // The world-space vertices of triangle `prim` of mesh `mesh` at shutter time `time` (the
  // stored positions for a mesh that does not move).
  void triangle_at(int mesh, int prim, float time, Vec3 out[3]) const;
  // The shutter time of photon-method pass `pass` (thesis ch. 7: one time per pass, shared by
  // its photons and eye paths, so the shared statistics average over the shutter), drawn from
  // the render's seed and the pass (a stream of its own); 0 without motion, drawing nothing.
  float pass_shutter_time(uint64_t seed, uint64_t pass) const;
  // The media a path starting in the open is inside: the World's.
  MediumStack initial_medium_stack() const { return MediumStack(world_medium); }
  const Bounds3& bounds() const { return bounds_; }
  size_t triangle_count() const;
  const Material& material(int i) const { return materials[i]; }
  // The BSDF at a surface point: its material with the textures looked up at its uv. Every
  // integrator shades through these, so the photon and gradient methods see the same textures.
  Bsdf bsdf(const SurfaceHit& h) const {
    const Material& m = materials[h.material];
    if (!m.runs_graph()) return bsdf(h.material, h.uv, h.frame, h.ng, h.n_smooth);
    const shading::ShadingContext ctx = shading_context(h);
    Bsdf b(m, ctx);
    if (m.perturbs_normal()) b.set_surface_normals(h.frame.to_local(h.ng), h.frame.to_local(h.n_smooth));
    return b;
  }
  // What a material's node graph sees at a hit (Cycles' ShaderData): position, normals facing
  // the viewer, uv, tangents, its object (Texture Coordinate's Generated and Object, Object Info).
  shading::ShadingContext shading_context(const SurfacePoint& h, const Vec3& wo, const Vec3& n_smooth) const;
  shading::ShadingContext shading_context(const SurfaceHit& h) const {
    shading::ShadingContext c = shading_context(h, h.wo, h.n_smooth);
    c.ray = h.ray;
    return c;
  }
  // Per mesh: its transform, object-space bounds and random number (finalize/commit).
  const std::vector<shading::ShadingObject>& shading_objects() const { return shading_objects_; }
  Bsdf bsdf(int material, Vec2 uv) const { return Bsdf(materials[material], uv); }
  // The BSDF at a surface point kept from a hit (a measurement point): as bsdf(hit).
  Bsdf bsdf(int material, Vec2 uv, const Frame& frame, const Vec3& ng, const Vec3& n_smooth) const {
    return bsdf(bsdf_params(materials[material], uv), material, uv, frame, ng, n_smooth);
  }
  // The BSDF at a measurement point kept as (material, ShadePoint, p, wo (world, unit), frame,
  // ng, n_smooth): as bsdf(hit), node graphs seeing the point's position and object.
  Bsdf bsdf(int material, const ShadePoint& at, const Vec3& p, const Vec3& wo, const Frame& frame, const Vec3& ng,
            const Vec3& n_smooth) const {
    const Material& m = materials[material];
    if (!m.runs_graph()) return bsdf(material, at.uv, frame, ng, n_smooth);
    SurfacePoint sp;
    sp.p = p;
    sp.ng = ng;
    sp.uv = at.uv;
    sp.bary = at.bary;
    sp.mesh = at.mesh;
    sp.prim = at.prim;
    sp.material = material;
    Bsdf b(m, shading_context(sp, wo, n_smooth));
    if (m.perturbs_normal()) b.set_surface_normals(frame.to_local(ng), frame.to_local(n_smooth));
    return b;
  }
  // A BSDF of parameters made for `material` at a surface point (one wavelength's, in the
  // spectral methods: monochromatic()), with the point's normals where a normal or bump map
  // bent them (the bump shadowing term and the geometric-side test), as bsdf(hit).
  Bsdf bsdf(const BsdfParams& params, int material, Vec2 uv, const Frame& frame, const Vec3& ng,
            const Vec3& n_smooth) const {
    Bsdf b(params, uv);
    if (materials[material].perturbs_normal()) b.set_surface_normals(frame.to_local(ng), frame.to_local(n_smooth));
    return b;
  }
  Bsdf bsdf(const BsdfParams& params, const SurfaceHit& h) const {
    return bsdf(params, h.material, h.uv, h.frame, h.ng, h.n_smooth);
  }
  // The texture coordinate at point p of a triangle (a vertex a manifold walk moved).
  Vec2 uv_at(int mesh, int prim, const Vec3& p) const { return point_at(mesh, prim, p).uv; }
  // Point p of a triangle as a hit there would give it (barycentrics of p's projection).
  SurfacePoint point_at(int mesh, int prim, const Vec3& p) const;
  // The BSDF at point p of a triangle seen from wo (world, unit) with shading normal ns: a
  // vertex a manifold walk moved, its node graph seeing the whole point (position, object).
  Bsdf bsdf_at(int mesh, int prim, const Vec3& p, const Vec3& wo, const Vec3& ns) const {
    const SurfacePoint sp = point_at(mesh, prim, p);
    return bsdf(sp.material, ShadePoint(sp), p, wo, Frame(ns), sp.ng, ns);
  }
  // The raw accelerator, for benchmarks that measure Embree without shading.
  const Accelerator& accelerator() const { return *accel_; }

 private:
  Frame tangent_frame(const Material& anisotropic, const SurfaceHit& h) const;  // scene.cpp
  std::unique_ptr<Accelerator> accel_;
  std::vector<shading::ShadingObject> shading_objects_;
  void build_shading_objects();
  // From `camera` (finalize, commit, set_camera); on the heap, so the area lights' pointers to
  // it (EmissionGraph::camera) survive the scene being moved.
  std::unique_ptr<shading::ShadingCamera> shading_camera_ = std::make_unique<shading::ShadingCamera>();
  void build_shading_camera();
  LightSet light_set_;
  Bounds3 bounds_;
  std::vector<std::vector<int32_t>> triangle_light_;  // per mesh, per triangle: light or -1
  std::vector<size_t> changed_meshes_, moved_meshes_;  // for the accelerator at commit()
  uint64_t generation_ = 0;
  bool lights_hidden_from_some_lobes_ = false;
  bool surfaces_hidden_from_some_lobes_ = false;
  bool has_media_ = false, has_grid_media_ = false, has_transparent_shadows_ = false;
  bool has_holdout_ = false;
  // Renders holding the scene (> 0), an update (-1) or neither (0).
  std::unique_ptr<std::atomic<int>> state_ = std::make_unique<std::atomic<int>>(0);

  void build_lights();  // validation, area lights, light set and bounds (finalize, commit)
  void check_mesh_motion(const Mesh& m, const std::string& where);
  // What shading needs of a hit (ray_dir: the normal map keeps the view side valid).
  std::optional<SurfaceHit> surface_hit(const RawHit& raw, const Ray& ray) const;
  void surface_point(const RawHit& raw, SurfacePoint& out) const;  // what both hits share
};

}  // namespace gp
