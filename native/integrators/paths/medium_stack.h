// The media a point is inside, for paths that do not start in the open: the photons of a light
// inside a mesh's medium (a lamp in a glass of murky water, an emitter in a Volume box) start in
// that medium, not in the World's (photon/photon_walk.h). Found as Cycles' volume_stack_init finds
// the camera's media (intern/cycles/kernel/integrator/volume_stack.h): rays from the point,
// counting the volume boundaries they cross on the way out.
#pragma once

#include <cstdint>
#include <vector>

#include "media/medium.h"
#include "scene/scene.h"

namespace gp {

// The World's medium and those of the closed meshes around p whose material has an interior
// medium (Material::interior): a mesh is around p when a ray from p leaves it once more than it
// enters it (Cycles' rule: a ray leaves a medium through the back of its boundary), by the
// majority of three rays.
MediumStack medium_stack_at(const Scene& scene, const Vec3& p);

// The media each light of a scene is inside, found once (per light: its position, an emissive
// triangle's centre; distant lights and the World: the World's alone).
class LightMedia {
 public:
  LightMedia() = default;
  explicit LightMedia(const Scene& scene);
  // The media light `light` (a LightSet index) is inside.
  MediumStack of(int light) const {
    const size_t l = static_cast<size_t>(light);
    return l < stack_of_.size() && stack_of_[l] >= 0 ? stacks_[static_cast<size_t>(stack_of_[l])] : world_;
  }

 private:
  MediumStack world_;
  std::vector<MediumStack> stacks_;  // the distinct stacks other than the World's alone
  std::vector<int32_t> stack_of_;    // per light: an index into stacks_, or -1 (world_)
};

}  // namespace gp
