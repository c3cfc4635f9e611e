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
// majority of three rays. `camera`: as the camera's stack, traced as camera rays (Cycles'
// integrator_volume_stack_init traces with PATH_RAY_CAMERA visibility): a mesh whose material
// is hidden from camera rays (Material::visible_to_camera) is not around p; the World's medium
// always is, as Cycles' background volume.
MediumStack medium_stack_at(const Scene& scene, const Vec3& p, bool camera = false);

// The media camera rays start in. Cycles finds them per camera ray at the ray's origin, on the
// near clip plane (integrator_volume_stack_init, kernel/integrator/intersect_volume_stack.h: one
// ray out, a boundary left and not entered first is a medium around the origin), when
// Camera::device_update_volume (scene/camera.cpp) finds a volume object's bounds touching those
// of the clip plane; so a camera inside a Volume cube or under murky water sees through that
// medium from its first segment, and a volume boundary the clip start leaves behind counts as
// crossed. That ray is traced with camera-ray visibility: a Volume cube hidden from the camera
// (Object > Visibility > Camera off) is not around it, so camera rays see no fog inside it (and
// enter it neither, as they pass its boundary); the World's volume always is.
// Here the same stack at each camera ray's origin, at the least cost the scene allows:
//   - the World's alone when no medium mesh's bounds come near any camera ray's origin over the
//     shutter (the usual scene: no work per ray);
//   - else, when neither the camera nor a medium mesh moves, the stack at the camera's eye found
//     once, carried to each ray's origin across the boundaries in between (the clip start, a
//     thin lens, an orthographic plane): one short ray, none where the origin is the eye;
//   - else (motion blur) medium_stack_at the ray's origin at its time.
class CameraMedia {
 public:
  CameraMedia() = default;  // every camera ray in the World's medium
  explicit CameraMedia(const Scene& scene);
  // The media around camera ray `ray`'s origin (at the thread's shutter time).
  MediumStack at(const Scene& scene, const Ray& ray) const;

 private:
  enum class Mode : uint8_t { World, FromEye, Probe };
  Mode mode_ = Mode::World;
  MediumStack eye_stack_;  // FromEye: the media around the eye
  Vec3 eye_{0.0f};
};

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
