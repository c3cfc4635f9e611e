// The media a point is inside (paths/medium_stack.h).
#include "integrators/paths/medium_stack.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace gp {

namespace {
// Three directions, none along an axis (the boxes and quads of scenes are axis-aligned, so a ray
// along an axis would graze their edges); the majority of their answers is kept.
const std::array<Vec3, 3> kProbe = {normalize(Vec3(0.2113f, 0.3419f, 0.9155f)), normalize(Vec3(-0.7071f, 0.5257f, -0.4721f)),
                                    normalize(Vec3(0.5878f, -0.8090f, 0.0309f))};
constexpr int kMaxCrossings = 256;  // a ray crosses at most this many surfaces (no hang on bad meshes)
}  // namespace

MediumStack medium_stack_at(const Scene& scene, const Vec3& p, bool camera) {
  MediumStack stack = scene.initial_medium_stack();
  // Per probe: (mesh, medium) -> boundaries left minus boundaries entered along the ray to the
  // open. A closed mesh around p is left once more than entered (Cycles' rule: a ray leaves a
  // medium through the back of its boundary, dot(d, ng) > 0); one p is outside of, as often.
  struct Count {
    int mesh, medium, net[kProbe.size()];
  };
  std::vector<Count> counts;
  for (size_t k = 0; k < kProbe.size(); ++k) {
    const Vec3 d = kProbe[k];
    Vec3 o = p;
    for (int crossing = 0; crossing < kMaxCrossings; ++crossing) {
      Ray ray(o, d);
      ray.camera = camera;  // surfaces hidden from camera rays let the camera's probe through
      const std::optional<SurfacePoint> hit = scene.intersect_point(ray);
      if (!hit) break;
      const int medium = scene.material(hit->material).interior;
      if (medium >= 0) {
        auto it = std::find_if(counts.begin(), counts.end(),
                               [&](const Count& c) { return c.mesh == hit->mesh && c.medium == medium; });
        if (it == counts.end()) it = counts.insert(counts.end(), Count{hit->mesh, medium, {0, 0, 0}});
        it->net[k] += dot(d, hit->ng) > 0 ? 1 : -1;
      }
      o = offset_ray_origin(hit->p, hit->ng, d);
    }
  }
  for (const Count& c : counts) {
    int inside = 0;
    for (int n : c.net) inside += n > 0;
    if (2 * inside > static_cast<int>(kProbe.size())) stack.cross(c.mesh, c.medium, true);
  }
  return stack;
}

namespace {
// The boundaries of meshes with an interior medium between `from` and `to`, crossed in `stack`
// (a stack carried along a segment, as Cycles' integrator_volume_stack_update_for_subsurface),
// seen as a camera ray sees them (CameraMedia: camera-ray visibility).
void cross_between(const Scene& scene, MediumStack& stack, const Vec3& from, const Vec3& to) {
  float remaining = length(to - from);
  if (!(remaining > 0)) return;
  const Vec3 d = (to - from) / remaining;
  Vec3 o = from;
  for (int crossing = 0; crossing < kMaxCrossings; ++crossing) {
    Ray ray(o, d, 0.0f, remaining);
    ray.camera = true;
    const std::optional<SurfacePoint> hit = scene.intersect_point(ray);
    if (!hit) return;
    const int medium = scene.material(hit->material).interior;
    if (medium >= 0) stack.cross(hit->mesh, medium, dot(d, hit->ng) < 0);
    o = offset_ray_origin(hit->p, hit->ng, d);
    remaining = length(to - o);
    if (dot(to - o, d) <= 0) return;  // the offset stepped past `to`
  }
}

// How far from the camera's eye (camera space, before its matrix's scale) a camera ray can start:
// the clip start along the widest ray, plus the lens or the orthographic plane's extent.
float origin_reach(const Camera& c) {
  const Vec2 ext = c.half_extent();
  const float s = 2.0f * std::max(ext.x, ext.y);  // Blender's shift is a fraction of this
  const float x = ext.x + std::abs(c.shift.x) * s, y = ext.y + std::abs(c.shift.y) * s;
  if (c.projection == Projection::Orthographic) return std::sqrt(x * x + y * y) + c.clip_start;
  return c.aperture_radius + c.clip_start * std::sqrt(x * x + y * y + 1.0f);
}
}  // namespace

CameraMedia::CameraMedia(const Scene& scene) {
  if (!scene.finalized() || !scene.has_media()) return;
  // Where camera rays start over the shutter: boxes around the eye at each camera step (the eye
  // moves linearly between steps; the box holds every turn of the camera about it).
  const Camera& cam = scene.camera;
  const size_t steps = std::max<size_t>(1, cam.motion.size());
  const float reach = origin_reach(cam);
  Bounds3 origins;
  for (size_t i = 0; i < steps; ++i) {
    const Transform m = cam.to_world_at(steps == 1 ? 0.0f : static_cast<float>(i) / static_cast<float>(steps - 1));
    const float scale = std::max({length(m.vector({1, 0, 0})), length(m.vector({0, 1, 0})), length(m.vector({0, 0, 1}))});
    const Vec3 eye = m.point({0, 0, 0}), r(reach * scale * 1.001f + 1e-4f * (1.0f + length(eye)));
    origins.extend(eye - r);
    origins.extend(eye + r);
  }
  // The meshes with an interior medium visible to camera rays whose bounds meet that region (a
  // moving one always).
  bool near = false, moving = !cam.motion.empty();
  for (const Mesh& mesh : scene.meshes) {
    if (std::none_of(mesh.material_ids.begin(), mesh.material_ids.end(), [&](uint32_t id) {
          const Material& m = scene.material(static_cast<int>(id));
          return m.interior >= 0 && m.visible_to_camera;
        }))
      continue;
    if (mesh.motion) {
      near = moving = true;
      continue;
    }
    Bounds3 b;
    for (const Vec3& p : mesh.positions) b.extend(p);
    near = near || (b.lo.x <= origins.hi.x && b.hi.x >= origins.lo.x && b.lo.y <= origins.hi.y &&
                    b.hi.y >= origins.lo.y && b.lo.z <= origins.hi.z && b.hi.z >= origins.lo.z);
  }
  if (!near) return;  // every camera ray starts in the World's medium alone
  if (moving) {
    mode_ = Mode::Probe;
    return;
  }
  mode_ = Mode::FromEye;
  eye_ = cam.camera_to_world.point({0, 0, 0});
  eye_stack_ = medium_stack_at(scene, eye_, true);
}

MediumStack CameraMedia::at(const Scene& scene, const Ray& ray) const {
  switch (mode_) {
    case Mode::World:
      return scene.initial_medium_stack();
    case Mode::FromEye: {
      MediumStack stack = eye_stack_;
      if (ray.o.x != eye_.x || ray.o.y != eye_.y || ray.o.z != eye_.z) cross_between(scene, stack, eye_, ray.o);
      return stack;
    }
    case Mode::Probe:
      break;
  }
  return medium_stack_at(scene, ray.o, true);
}

LightMedia::LightMedia(const Scene& scene) : world_(scene.initial_medium_stack()) {
  // Only meshes' media can surround a light: without any, every light is in the World's.
  if (std::none_of(scene.materials.begin(), scene.materials.end(), [](const Material& m) { return m.interior >= 0; }))
    return;
  const std::vector<Light>& all = scene.light_set().lights();
  stack_of_.assign(all.size(), -1);
  for (size_t l = 0; l < all.size(); ++l) {
    const Light& light = all[l];
    if (light.is_infinite()) continue;  // its photons come from outside the scene
    // Where its photons leave from: a lamp's position, an emissive triangle's centre pushed off
    // its front (a two-sided emitter lies inside one medium on both sides).
    const Vec3 at = light.type == LightType::Area
                        ? offset_ray_origin((light.p0 + light.p1 + light.p2) / 3.0f, light.n, light.n)
                        : light.position;
    const MediumStack s = medium_stack_at(scene, at);
    if (s.size() == world_.size()) continue;  // the World's alone
    auto same = [&](const MediumStack& o) {
      if (o.size() != s.size()) return false;
      for (int i = 0; i < s.size(); ++i)
        if (o[i].mesh != s[i].mesh || o[i].medium != s[i].medium) return false;
      return true;
    };
    auto it = std::find_if(stacks_.begin(), stacks_.end(), same);
    if (it == stacks_.end()) it = stacks_.insert(stacks_.end(), s);
    stack_of_[l] = static_cast<int32_t>(it - stacks_.begin());
  }
}

}  // namespace gp
