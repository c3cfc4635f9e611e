// Camera with Blender's conventions: looks down its local -Z with +Y up, the image's extent on
// the axis chosen by the sensor fit, optional thin lens (perspective), lens shift, and a crop
// window (a border render: only the window's pixels are traced and the film holds only them).
#pragma once

#include <cstddef>
#include <string>

#include "core/math.h"
#include "core/motion.h"
#include "core/rng.h"

namespace gp {

enum class SensorFit { Auto, Horizontal, Vertical };
enum class Projection { Perspective, Orthographic };

struct Camera {
  Transform camera_to_world;
  Projection projection = Projection::Perspective;
  float fov_degrees = 40.0f;  // perspective: full angle on the fitted axis
  float ortho_scale = 1.0f;   // orthographic: full extent on the fitted axis in metres (Blender's Orthographic Scale)
  SensorFit sensor_fit = SensorFit::Auto;
  int width = 256, height = 256;  // the whole image, in pixels
  // Blender's Shift X/Y: the image plane moved by this fraction of its larger extent.
  Vec2 shift{0.0f, 0.0f};
  float aperture_radius = 0.0f;  // metres; 0 = pinhole (perspective only)
  float focus_distance = 1.0f;   // metres along the view axis
  // Blender's Clip Start / Clip End (metres along the view axis), as Cycles clips camera rays
  // (kernel/camera/camera.h camera_sample_perspective): a ray starts on the near clip plane and
  // ends on the far one, so nothing nearer than clip_start is seen, and no medium in front of it
  // (World fog between the camera and the plane is skipped). 0 and infinity: no clipping.
  float clip_start = 0.0f, clip_end = kInfinity;
  // Film > Pixel Filter (core/pixel_filter.h): each camera ray's film offset is drawn from it.
  PixelFilter filter;
  // Crop window in pixels of the whole image (0,0 = top-left corner); crop_width 0 = none.
  int crop_x = 0, crop_y = 0, crop_width = 0, crop_height = 0;
  // Motion blur: camera-to-world at S >= 2 evenly spaced shutter times (scene-format "motion"),
  // interpolated as objects' (core/motion.h); empty: camera_to_world throughout the shutter.
  TransformMotion motion;
  // Whether camera paths draw a shutter time: something in the scene moves (the camera or a mesh;
  // set by Scene::finalize and commit). Without, no time is drawn and images are as before.
  bool motion_blur = false;

  // Camera-to-world at shutter time t.
  Transform to_world_at(float t) const { return motion.empty() ? camera_to_world : motion.at(t); }

  // The pixels the integrators trace and their film holds: the crop window, or the image.
  int film_width() const { return crop_width > 0 ? crop_width : width; }
  int film_height() const { return crop_width > 0 ? crop_height : height; }
  // The key of film pixel (x, y)'s random stream: its index in the whole image, so a pixel of a
  // crop draws the same numbers as in the whole image (a border render matches the full one).
  size_t pixel_key(int x, int y) const {
    return static_cast<size_t>(y + crop_y) * static_cast<size_t>(width) + static_cast<size_t>(x + crop_x);
  }

  // Ray through position (x, y) in pixels of the whole image (0,0 = its top-left corner; a crop
  // window's film pixel (x, y) lies at (x + crop_x, y + crop_y)) with lens sample u_lens in
  // [0,1)^2, at shutter time `time` (the camera where it is then; the ray's Ray::time): by
  // default the thread's path or pass time. Direction is normalised.
  Ray generate_ray(Vec2 film, Vec2 u_lens) const { return generate_ray(film, u_lens, half_extent()); }
  // The same with half_extent() computed once by a caller that makes many rays (it costs a tan).
  Ray generate_ray(Vec2 film, Vec2 u_lens, Vec2 half_extent, float time = shutter_time()) const;
  // Half-extents of the image plane: at distance 1 (tan of the half angles) for a perspective
  // camera, in metres for an orthographic one.
  Vec2 half_extent() const;
  // Width of one pixel's footprint at `distance` along a camera ray (the ray-cone approximation
  // of ray differentials that photon methods use to size their first radius).
  float pixel_footprint(float distance) const { return pixel_footprint(distance, half_extent()); }
  float pixel_footprint(float distance, Vec2 half_extent) const;
  Vec3 position() const { return to_world_at(shutter_time()).point({0, 0, 0}); }
  // An empty string, or what is wrong (a crop outside the image, a non-finite value).
  std::string check() const;
};

// start_pixel (core/rng.h) for film pixel (x, y) of `camera`: the random stream of its place in
// the whole image and a film position in the whole image's pixels, for generate_ray (so a crop
// window's pixel takes exactly the ray it takes in the whole image).
// With motion blur (Camera::motion_blur) the camera path's shutter time is drawn last from the
// pixel's stream (pt, spt, gpt: one time per camera path), so a scene without motion draws the
// same numbers as before.
inline PixelStart start_pixel(const Camera& camera, uint64_t seed, uint64_t pass, int x, int y) {
  PixelStart s = start_pixel(seed, camera.pixel_key(x, y), pass, x + camera.crop_x, y + camera.crop_y, &camera.filter);
  if (camera.motion_blur) s.time = s.rng.uniform();
  return s;
}
// The same for a method whose passes each have one time (the photon methods): the pixel's
// stream as without motion, the time the thread's pass time (Scene::pass_shutter_time).
inline PixelStart start_pixel_in_pass(const Camera& camera, uint64_t seed, uint64_t pass, int x, int y) {
  PixelStart s = start_pixel(seed, camera.pixel_key(x, y), pass, x + camera.crop_x, y + camera.crop_y, &camera.filter);
  s.time = shutter_time();
  return s;
}

}  // namespace gp
