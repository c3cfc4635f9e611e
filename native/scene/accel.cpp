#include "scene/accel.h"

#include <embree3/rtcore.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <stdexcept>

#include "core/rng.h"
#include "scene/scene.h"
#include "scene/shapes.h"  // linear_determinant

namespace gp {

namespace {
std::atomic<RayRecorder*> g_recorder{nullptr};
std::mutex g_recorder_mutex;

void record(const Ray& ray, bool shadow) {
  RayRecorder* r = g_recorder.load(std::memory_order_relaxed);
  if (!r) return;
  std::lock_guard lock(g_recorder_mutex);
  auto& v = shadow ? r->shadow : r->closest;
  if (v.size() < r->limit) v.push_back(ray);
}
}  // namespace

void Accelerator::record_rays(RayRecorder* recorder) { g_recorder.store(recorder); }

// Per-triangle ray visibility of one mesh, for its filter functions.
struct TriangleVisibility {
  // kHiddenFromCamera | kNoShadow | kHiddenFrom<lobe> | kTransparentShadow per triangle
  std::vector<uint8_t> flags;
};
// (Bit 4 was an alpha cut-out's: Principled Alpha is now a Mix with a Transparent BSDF, whose
// shadow rays kTransparentShadow lets through.)
constexpr uint8_t kHiddenFromCamera = 1, kNoShadow = 2;
// Hidden from bounce rays of a kind: the Ray::bounce bit shifted past the flags above.
constexpr int kLobeShift = 2;  // kRayDiffuse (2) -> 8, kRayGlossy (4) -> 16, kRayTransmission (8) -> 32
constexpr uint8_t kHiddenFromLobes = kAllLobes << kLobeShift;
// A Transparent BSDF in the material (Material::transparent_shadow): opaque to occluded(), let
// through and noted by occluded_opaque().
constexpr uint8_t kTransparentShadow = 64;

// An intersect context that says which flag hides a triangle from the ray (camera rays:
// kHiddenFromCamera; bounce rays of a kind: that kind's; else none). Embree passes the context
// to filter functions; extending it is Embree's documented way to hand them per-ray data.
struct VisibilityContext {
  RTCIntersectContext ctx;
  uint8_t hidden;
};
// The context of shadow queries (occluded filters): which flags let the ray through (kNoShadow,
// and kTransparentShadow for occluded_opaque), and whether a kTransparentShadow triangle was
// crossed.
struct ShadowContext {
  RTCIntersectContext ctx;
  uint8_t through;
  bool crossed;
};
uint8_t hidden_flag(const Ray& ray) {
  return ray.camera ? kHiddenFromCamera : static_cast<uint8_t>((ray.bounce & kAllLobes) << kLobeShift);
}

// Mesh i's triangles are geometry i of one of three Embree scenes: `scene` (the top level) while
// nothing has moved; once something has, `object[i]` (its own BVH in object space, instanced as
// instance i of the top level) when mesh i has moved, else `unmoved` (one BVH of the meshes never
// moved, instanced unmoved as instance `unmoved_id`). The geometry ID is the mesh index in all
// three, so a hit's geomID is the mesh index whichever level it came from.
struct Accelerator::Impl {
  static constexpr uint8_t kNotBuilt = 2;
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  RTCScene unmoved = nullptr;
  unsigned unmoved_id = 0;
  std::vector<RTCScene> object;        // per mesh: its own BVH once it has moved, else null
  std::vector<uint8_t> object_mirror;  // per moved mesh: the winding its triangles have (det < 0) or kNotBuilt
  std::vector<unsigned> dirty;         // top-level instances whose lower BVH changed since commit()
  std::vector<std::unique_ptr<TriangleVisibility>> visibility;  // per mesh, null without filters

  RTCScene new_scene() const {
    RTCScene s = rtcNewScene(device);
    rtcSetSceneFlags(s, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_HIGH);
    return s;
  }
  RTCScene home(size_t i) const { return object[i] ? object[i] : unmoved ? unmoved : scene; }
  void split_levels();
};

namespace {

void reject_where(const RTCFilterFunctionNArguments* args, uint8_t flag) {
  const auto* vis = static_cast<const TriangleVisibility*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    const uint8_t f = vis->flags[prim];
    if (f & flag) args->valid[i] = 0;
  }
}
void intersect_filter(const RTCFilterFunctionNArguments* args) {
  reject_where(args, reinterpret_cast<const VisibilityContext*>(args->context)->hidden);
}
void shadow_filter(const RTCFilterFunctionNArguments* args) {
  auto* c = reinterpret_cast<ShadowContext*>(args->context);
  const auto* vis = static_cast<const TriangleVisibility*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    const uint8_t f = vis->flags[prim];
    if (f & kNoShadow) {
      args->valid[i] = 0;
    } else if (f & c->through & kTransparentShadow) {
      args->valid[i] = 0;
      c->crossed = true;
    }
  }
}
}  // namespace

// Embree is C: never throw through it. Errors are polled after each build step instead.
static void check_device(RTCDevice device, const char* what) {
  const RTCError code = rtcGetDeviceError(device);
  if (code != RTC_ERROR_NONE)
    throw std::runtime_error(fmt::format("Embree error {} while {}", static_cast<int>(code), what));
}

namespace {
// The object-space vertex arrays of a moving mesh's time steps.
std::vector<const std::vector<Vec3>*> object_steps(const MeshMotion& motion) {
  std::vector<const std::vector<Vec3>*> steps;
  if (motion.positions.empty()) steps.push_back(&motion.object_positions);
  for (const auto& p : motion.positions) steps.push_back(&p);
  return steps;
}

// An instance of `of` moving over the shutter: one quaternion-decomposed transform per time step
// (rtcSetGeometryTransformQuaternion, slerped by Embree), the decomposition core/motion.h uses
// for hits and lights.
RTCGeometry new_motion_instance(RTCDevice device, RTCScene of, const TransformMotion& motion) {
  RTCGeometry inst = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
  rtcSetGeometryInstancedScene(inst, of);
  rtcSetGeometryTimeStepCount(inst, static_cast<unsigned>(motion.size()));
  for (unsigned s = 0; s < motion.size(); ++s) {
    const DecomposedTransform& d = motion.steps()[s];
    RTCQuaternionDecomposition q;
    rtcInitQuaternionDecomposition(&q);
    rtcQuaternionDecompositionSetScale(&q, d.s00, d.s11, d.s22);
    rtcQuaternionDecompositionSetSkew(&q, d.s01, d.s02, d.s12);
    rtcQuaternionDecompositionSetQuaternion(&q, d.qr, d.qi, d.qj, d.qk);
    rtcQuaternionDecompositionSetTranslation(&q, d.translation.x, d.translation.y, d.translation.z);
    rtcSetGeometryTransformQuaternion(inst, s, &q);
  }
  rtcCommitGeometry(inst);
  return inst;
}

// Sets a (possibly moving) instance back to one fixed transform.
void set_instance_transform(RTCGeometry inst, const Transform& to_world) {
  rtcSetGeometryTimeStepCount(inst, 1);
  // Transform::m is row-major: its first three rows are Embree's 3x4 row-major matrix.
  rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &to_world.m[0][0]);
}

// One mesh as an Embree triangle geometry with vertices `positions` (its world-space ones, or its
// object-space ones for an instanced mesh), with its ray-visibility filters; `keep` receives the
// filters' per-triangle flags (they must outlive the geometry's use in traversal).
// `steps`: the vertex arrays of its time steps (one for a mesh that does not deform; S' >= 2 for
// a deforming one, Embree's linear motion blur), each mapped by `to_world` where given.
RTCGeometry make_geometry(RTCDevice device, const std::vector<const std::vector<Vec3>*>& steps, const Transform* to_world,
                          const Mesh& m, const std::vector<Material>* materials,
                          std::unique_ptr<TriangleVisibility>& keep) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (steps.size() > 1) rtcSetGeometryTimeStepCount(g, static_cast<unsigned>(steps.size()));
  for (unsigned s = 0; s < steps.size(); ++s) {
    const std::vector<Vec3>& positions = *steps[s];
    // Embree-owned buffers (a copy): Embree may read up to 16 bytes past a shared vertex
    // buffer, and owning them keeps the accelerator valid if a Mesh vector reallocates.
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, s, RTC_FORMAT_FLOAT3, sizeof(Vec3), positions.size()));
    // (An empty mesh has no data pointer to take ->x of: found by fuzz_obj on an empty file.)
    for (size_t v = 0; v < positions.size(); ++v) {
      const Vec3 p = to_world ? to_world->point(positions[v]) : positions[v];
      for (int k = 0; k < 3; ++k) vb[3 * v + k] = p[k];
    }
  }
  auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), m.triangle_count()));
  std::copy(m.indices.begin(), m.indices.end(), ib);
  if (materials) {
    auto vis = std::make_unique<TriangleVisibility>();
    vis->flags.resize(m.triangle_count(), 0);
    uint8_t any = 0;
    for (size_t t = 0; t < m.triangle_count() && t < m.material_ids.size(); ++t) {
      const Material& mat = (*materials)[m.material_ids[t]];
      vis->flags[t] = (mat.visible_to_camera ? 0 : kHiddenFromCamera) | (mat.casts_shadow ? 0 : kNoShadow) |
                      (mat.transparent_shadow() ? kTransparentShadow : 0) |
                      static_cast<uint8_t>((~mat.visible_lobes & kAllLobes) << kLobeShift);
      any |= vis->flags[t];
    }
    if (any) {
      rtcSetGeometryUserData(g, vis.get());
      if (any & (kHiddenFromCamera | kHiddenFromLobes)) rtcSetGeometryIntersectFilterFunction(g, intersect_filter);
      // (Only meshes with such triangles pay for a filter: a scene without them traces as before.)
      if (any & (kNoShadow | kTransparentShadow)) rtcSetGeometryOccludedFilterFunction(g, shadow_filter);
      keep = std::move(vis);
    }
  }
  rtcCommitGeometry(g);
  return g;
}
}  // namespace

Accelerator::Accelerator(const std::vector<Mesh>& meshes, const std::vector<Material>* materials)
    : impl_(std::make_unique<Impl>()) {
#if GRADPHOTON_PARALLEL_THREADS
  // The ThreadSanitizer build (core/parallel.cpp): Embree's BVH build on the calling thread only,
  // so that TSan, which cannot see inside the uninstrumented Embree, sees no threads of its own.
  impl_->device = rtcNewDevice("threads=1");
#else
  impl_->device = rtcNewDevice(nullptr);
#endif
  if (!impl_->device) throw std::runtime_error("cannot create Embree device");
  impl_->scene = impl_->new_scene();
  impl_->visibility.resize(meshes.size());
  impl_->object.assign(meshes.size(), nullptr);
  impl_->object_mirror.assign(meshes.size(), 0);
  for (size_t i = 0; i < meshes.size(); ++i) {
    const Mesh& m = meshes[i];
    const MeshMotion* motion = m.motion.get();
    if (motion && !motion->transform.empty()) {
      // Object motion: its object-space triangles (deforming or not) in a BVH of their own,
      // instanced under the transform's steps (as Cycles' bvh/embree.cpp add_instance).
      impl_->object[i] = impl_->new_scene();
      RTCGeometry g = make_geometry(impl_->device, object_steps(*motion), nullptr, m, materials, impl_->visibility[i]);
      rtcAttachGeometryByID(impl_->object[i], g, static_cast<unsigned>(i));
      rtcReleaseGeometry(g);
      rtcCommitScene(impl_->object[i]);
      RTCGeometry inst = new_motion_instance(impl_->device, impl_->object[i], motion->transform);
      rtcAttachGeometryByID(impl_->scene, inst, static_cast<unsigned>(i));
      rtcReleaseGeometry(inst);
      impl_->object_mirror[i] = linear_determinant(m.to_world) < 0;
      continue;
    }
    // Deformation alone: world-space steps in the flat BVH.
    RTCGeometry g = motion ? make_geometry(impl_->device, object_steps(*motion), &motion->to_world, m, materials,
                                           impl_->visibility[i])
                           : make_geometry(impl_->device, {&m.positions}, nullptr, m, materials, impl_->visibility[i]);
    rtcAttachGeometryByID(impl_->scene, g, static_cast<unsigned>(i));
    rtcReleaseGeometry(g);
  }
  commit();
}

namespace {
RTCGeometry new_instance(RTCDevice device, RTCScene of, const Transform& to_world) {
  RTCGeometry inst = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
  rtcSetGeometryInstancedScene(inst, of);
  // Transform::m is row-major: its first three rows are Embree's 3x4 row-major matrix.
  rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &to_world.m[0][0]);
  rtcCommitGeometry(inst);
  return inst;
}
}  // namespace

// The first move: every mesh's triangles leave the top level for the BVH of the unmoved meshes
// (the same geometries, filters and all: nothing is copied), instanced unmoved. Embree's
// identity instance maps rays exactly (x * 1 + 0), so their hits do not change.
void Accelerator::Impl::split_levels() {
  unmoved = new_scene();
  unmoved_id = static_cast<unsigned>(object.size());
  for (unsigned i = 0; i < unmoved_id; ++i) {
    if (object[i]) continue;  // a moving object: an instance of its own already
    RTCGeometry g = rtcGetGeometry(scene, i);
    rtcRetainGeometry(g);
    rtcDetachGeometry(scene, i);
    rtcAttachGeometryByID(unmoved, g, i);
    rtcReleaseGeometry(g);
  }
  RTCGeometry inst = new_instance(device, unmoved, Transform());
  rtcAttachGeometryByID(scene, inst, unmoved_id);
  rtcReleaseGeometry(inst);
  dirty.push_back(unmoved_id);
}

void Accelerator::move_mesh(size_t index, const Mesh& mesh, const std::vector<Material>* materials) {
  // No ray is traced between here and commit() (Scene's updates wait for renders to end), so
  // geometries and their visibility flags may go at once.
  if (index >= impl_->object.size()) throw std::out_of_range("Accelerator::move_mesh: no such mesh");
  if (!mesh.source) throw std::invalid_argument("Accelerator::move_mesh: the mesh has no object-space arrays");
  Impl& im = *impl_;
  const unsigned id = static_cast<unsigned>(index);
  if (!im.unmoved) im.split_levels();
  const uint8_t mirror = linear_determinant(mesh.to_world) < 0;
  if (!im.object[index]) {  // its first move: out of the unmoved meshes into a BVH of its own
    rtcDetachGeometry(im.unmoved, id);
    im.dirty.push_back(im.unmoved_id);
    im.object[index] = im.new_scene();
    RTCGeometry inst = new_instance(im.device, im.object[index], mesh.to_world);
    rtcAttachGeometryByID(im.scene, inst, id);
    rtcReleaseGeometry(inst);
    im.object_mirror[index] = Impl::kNotBuilt;
  }
  if (im.object_mirror[index] != mirror) {
    // Its triangles now, or again where a mirroring matrix came or went and transform_mesh
    // reversed the mesh's winding: hit barycentrics must refer to mesh.indices' order.
    replace_mesh(index, mesh, materials);
  } else {
    RTCGeometry inst = rtcGetGeometry(im.scene, id);
    set_instance_transform(inst, mesh.to_world);
    rtcCommitGeometry(inst);
  }
  check_device(im.device, "moving a mesh");
}

void Accelerator::replace_mesh(size_t index, const Mesh& mesh, const std::vector<Material>* materials) {
  if (index >= impl_->object.size()) throw std::out_of_range("Accelerator::replace_mesh: no such mesh");
  Impl& im = *impl_;
  const unsigned id = static_cast<unsigned>(index);
  RTCScene home = im.home(index);
  const bool moved = im.object[index] != nullptr;
  if (!moved || im.object_mirror[index] != Impl::kNotBuilt) rtcDetachGeometry(home, id);
  im.visibility[index].reset();
  RTCGeometry g = make_geometry(im.device, {moved ? &mesh.source->positions : &mesh.positions}, nullptr, mesh,
                                materials, im.visibility[index]);
  rtcAttachGeometryByID(home, g, id);
  rtcReleaseGeometry(g);
  if (moved) {
    im.object_mirror[index] = linear_determinant(mesh.to_world) < 0;
    RTCGeometry inst = rtcGetGeometry(im.scene, id);
    set_instance_transform(inst, mesh.to_world);
  }
  if (home != im.scene) im.dirty.push_back(moved ? id : im.unmoved_id);
  check_device(im.device, "replacing a mesh");
}

void Accelerator::commit() {
  Impl& im = *impl_;
  std::sort(im.dirty.begin(), im.dirty.end());
  im.dirty.erase(std::unique(im.dirty.begin(), im.dirty.end()), im.dirty.end());
  for (unsigned id : im.dirty) {  // lower levels first, then their instances (new bounds)
    rtcCommitScene(id == im.unmoved_id ? im.unmoved : im.object[id]);
    rtcCommitGeometry(rtcGetGeometry(im.scene, id));
  }
  im.dirty.clear();
  rtcCommitScene(im.scene);
  check_device(im.device, "building the scene");
}

bool Accelerator::instanced(size_t index) const { return index < impl_->object.size() && impl_->object[index]; }

Accelerator::~Accelerator() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);  // (its instances first: they use the others)
  for (RTCScene s : impl_->object)
    if (s) rtcReleaseScene(s);
  if (impl_->unmoved) rtcReleaseScene(impl_->unmoved);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

namespace {
void to_embree(const Ray& ray, RTCRay& r) {
  r.org_x = ray.o.x; r.org_y = ray.o.y; r.org_z = ray.o.z;
  r.dir_x = ray.d.x; r.dir_y = ray.d.y; r.dir_z = ray.d.z;
  r.tnear = ray.tmin;
  r.tfar = ray.tmax;
  r.time = ray.time;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
}
bool from_embree(const RTCRayHit& rh, RawHit& hit) {
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  hit.t = rh.ray.tfar;
  hit.u = rh.hit.u;
  hit.v = rh.hit.v;
  hit.ng = Vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
  hit.geom = static_cast<int>(rh.hit.geomID);
  hit.prim = static_cast<int>(rh.hit.primID);
  hit.time = rh.ray.time;
  return true;
}
}  // namespace

bool Accelerator::intersect(const Ray& ray, RawHit& hit) const {
  record(ray, false);
  VisibilityContext vctx;
  rtcInitIntersectContext(&vctx.ctx);
  vctx.hidden = hidden_flag(ray);
  RTCRayHit rh;
  to_embree(ray, rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &vctx.ctx, &rh);
  return from_embree(rh, hit);
}

bool Accelerator::occluded(const Ray& ray) const {
  record(ray, true);
  ShadowContext sctx;
  rtcInitIntersectContext(&sctx.ctx);
  sctx.through = kNoShadow;
  RTCRay r;
  to_embree(ray, r);
  rtcOccluded1(impl_->scene, &sctx.ctx, &r);
  return r.tfar < 0;  // Embree sets tfar = -inf on a hit
}

bool Accelerator::occluded_opaque(const Ray& ray, bool* crossed) const {
  record(ray, true);
  ShadowContext sctx;
  rtcInitIntersectContext(&sctx.ctx);
  sctx.through = kNoShadow | kTransparentShadow;
  sctx.crossed = false;
  RTCRay r;
  to_embree(ray, r);
  rtcOccluded1(impl_->scene, &sctx.ctx, &r);
  *crossed = sctx.crossed;
  return r.tfar < 0;
}

bool Accelerator::intersect_shadow(const Ray& ray, RawHit& hit) const {
  VisibilityContext vctx;
  rtcInitIntersectContext(&vctx.ctx);
  vctx.hidden = kNoShadow;
  RTCRayHit rh;
  to_embree(ray, rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &vctx.ctx, &rh);
  return from_embree(rh, hit);
}

namespace {
// Per-thread buffers of the stream calls, kept between calls (no allocation per batch).
thread_local std::vector<RTCRayHit> t_rayhits;
thread_local std::vector<RTCRay> t_rays;
}  // namespace

void Accelerator::intersect_stream(const Ray* rays, size_t n, RawHit* hits, bool* found, bool coherent) const {
  t_rayhits.resize(n);
  // The hiding flag lives in the context, one per call: split the stream where it changes.
  for (size_t lo = 0; lo < n;) {
    size_t hi = lo + 1;
    while (hi < n && hidden_flag(rays[hi]) == hidden_flag(rays[lo])) ++hi;
    for (size_t i = lo; i < hi; ++i) {
      record(rays[i], false);
      RTCRayHit& rh = t_rayhits[i];
      to_embree(rays[i], rh.ray);
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    VisibilityContext vctx;
    rtcInitIntersectContext(&vctx.ctx);
    if (coherent) vctx.ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    vctx.hidden = hidden_flag(rays[lo]);
    rtcIntersect1M(impl_->scene, &vctx.ctx, t_rayhits.data() + lo, static_cast<unsigned>(hi - lo), sizeof(RTCRayHit));
    for (size_t i = lo; i < hi; ++i) found[i] = from_embree(t_rayhits[i], hits[i]);
    lo = hi;
  }
}

void Accelerator::occluded_stream(const Ray* rays, size_t n, bool* blocked, bool coherent) const {
  if (n == 0) return;
  t_rays.resize(n);
  for (size_t i = 0; i < n; ++i) {
    record(rays[i], true);
    to_embree(rays[i], t_rays[i]);
  }
  ShadowContext sctx;
  rtcInitIntersectContext(&sctx.ctx);
  sctx.through = kNoShadow;
  if (coherent) sctx.ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  rtcOccluded1M(impl_->scene, &sctx.ctx, t_rays.data(), static_cast<unsigned>(n), sizeof(RTCRay));
  for (size_t i = 0; i < n; ++i) blocked[i] = t_rays[i].tfar < 0;
}

}  // namespace gp
