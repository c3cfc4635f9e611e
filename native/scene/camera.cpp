#include "scene/camera.h"

#include "core/sampling.h"

namespace gp {

Vec2 Camera::tan_half_extent() const {
  const float t = std::tan(0.5f * fov_degrees * kPi / 180.0f);
  const float aspect = static_cast<float>(width) / static_cast<float>(height);
  bool horizontal = sensor_fit == SensorFit::Horizontal ||
                    (sensor_fit == SensorFit::Auto && width >= height);  // Blender's AUTO
  return horizontal ? Vec2(t, t / aspect) : Vec2(t * aspect, t);
}

Ray Camera::generate_ray(Vec2 film, Vec2 u_lens) const {
  const Vec2 ext = tan_half_extent();
  const float sx = (2.0f * film.x / width - 1.0f) * ext.x;
  const float sy = (1.0f - 2.0f * film.y / height) * ext.y;
  Vec3 dir{sx, sy, -1.0f};
  Vec3 origin{0, 0, 0};
  if (aperture_radius > 0) {
    // Thin lens: all rays through the pixel meet on the focus plane z = -focus_distance.
    const Vec3 focus = dir * focus_distance;
    const Vec2 lens = sample_uniform_disk_concentric(u_lens) * aperture_radius;
    origin = Vec3(lens.x, lens.y, 0);
    dir = focus - origin;
  }
  Ray ray(camera_to_world.point(origin), normalize(camera_to_world.vector(dir)));
  ray.camera = true;
  return ray;
}

}  // namespace gp
