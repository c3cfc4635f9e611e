#include "scene/camera.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/sampling.h"

namespace gp {

Vec2 Camera::half_extent() const {
  const float t = projection == Projection::Orthographic ? 0.5f * ortho_scale
                                                         : std::tan(0.5f * fov_degrees * kPi / 180.0f);
  const float aspect = static_cast<float>(width) / static_cast<float>(height);
  bool horizontal = sensor_fit == SensorFit::Horizontal ||
                    (sensor_fit == SensorFit::Auto && width >= height);  // Blender's AUTO
  return horizontal ? Vec2(t, t / aspect) : Vec2(t * aspect, t);
}

float Camera::pixel_footprint(float distance, Vec2 ext) const {
  const float pixel = 2.0f * ext.x / width;
  return projection == Projection::Orthographic ? pixel : pixel * distance;
}

Ray Camera::generate_ray(Vec2 film, Vec2 u_lens, Vec2 ext, float time) const {
  // Blender's shift is a fraction of the larger extent (Cycles: blender_camera_viewplane).
  const float s = 2.0f * std::max(ext.x, ext.y);
  const float sx = (2.0f * film.x / width - 1.0f) * ext.x + shift.x * s;
  const float sy = (1.0f - 2.0f * film.y / height) * ext.y + shift.y * s;
  Vec3 dir{sx, sy, -1.0f};
  Vec3 origin{0, 0, 0};
  if (projection == Projection::Orthographic) {
    origin = Vec3(sx, sy, 0);
    dir = Vec3(0, 0, -1);
  } else if (aperture_radius > 0) {
    // Thin lens: all rays through the pixel meet on the focus plane z = -focus_distance.
    const Vec3 focus = dir * focus_distance;
    const Vec2 lens = sample_uniform_disk_concentric(u_lens) * aperture_radius;
    origin = Vec3(lens.x, lens.y, 0);
    dir = focus - origin;
  }
  // A still camera uses its matrix as it is (no interpolation, no copy).
  const Transform moved = motion.empty() ? Transform() : motion.at(time);
  const Transform& to_world = motion.empty() ? camera_to_world : moved;
  Ray ray(to_world.point(origin), normalize(to_world.vector(dir)));
  if (clip_start > 0 || clip_end < kInfinity) {
    // Cycles' clipping: distances along the ray to the planes z = -clip_start and -clip_end,
    // from the pinhole direction through the film point (z_inv = 1 / cos of its angle to the
    // view axis; 1 for an orthographic camera), the thin lens's ray moved along its own direction.
    const float z_inv = projection == Projection::Orthographic ? 1.0f : length(Vec3(sx, sy, -1.0f));
    const float near = clip_start * z_inv;
    ray.o = ray.o + ray.d * near;
    ray.tmax = (clip_end - clip_start) * z_inv;
  }
  ray.time = time;
  ray.camera = true;
  ray.state = RayState::camera();
  return ray;
}

std::string Camera::check() const {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(camera_to_world.m[r][c])) return "the camera matrix is not finite";
  if (motion.size() == 1) return "the camera's motion has 1 matrix (at least 2 are needed)";
  for (const DecomposedTransform& d : motion.steps())
    if (!is_finite(d.translation) || !std::isfinite(d.qr + d.qi + d.qj + d.qk) || !std::isfinite(d.s00 * d.s11 * d.s22) ||
        !(d.s00 * d.s11 * d.s22 != 0))
      return "a camera motion matrix is not finite or is singular";
  if (width < 1 || height < 1) return fmt::format("the image is {}x{} pixels", width, height);
  if (!(std::isfinite(shift.x) && std::isfinite(shift.y))) return "the camera shift is not finite";
  if (!(clip_start >= 0 && std::isfinite(clip_start)) || !(clip_end > clip_start))
    return fmt::format("the camera's clip start {} and end {} must be 0 <= start < end", clip_start, clip_end);
  if (projection == Projection::Orthographic ? !(ortho_scale > 0 && std::isfinite(ortho_scale))
                                             : !(fov_degrees > 0 && fov_degrees < 180))
    return "the field of view must be above 0 (and below 180 degrees)";
  if (crop_width != 0 || crop_height != 0) {
    if (crop_width < 1 || crop_height < 1 || crop_x < 0 || crop_y < 0 || crop_x + crop_width > width ||
        crop_y + crop_height > height)
      return fmt::format("crop window {} {} {}x{} is not inside the {}x{} image", crop_x, crop_y, crop_width,
                         crop_height, width, height);
  }
  return {};
}

}  // namespace gp
