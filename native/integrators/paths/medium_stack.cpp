// The media a point is inside (paths/medium_stack.h).
#include "integrators/paths/medium_stack.h"

#include <algorithm>
#include <array>

namespace gp {

namespace {
// Three directions, none along an axis (the boxes and quads of scenes are axis-aligned, so a ray
// along an axis would graze their edges); the majority of their answers is kept.
const std::array<Vec3, 3> kProbe = {normalize(Vec3(0.2113f, 0.3419f, 0.9155f)), normalize(Vec3(-0.7071f, 0.5257f, -0.4721f)),
                                    normalize(Vec3(0.5878f, -0.8090f, 0.0309f))};
constexpr int kMaxCrossings = 256;  // a ray crosses at most this many surfaces (no hang on bad meshes)
}  // namespace

MediumStack medium_stack_at(const Scene& scene, const Vec3& p) {
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
      const std::optional<SurfacePoint> hit = scene.intersect_point(Ray(o, d));
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
