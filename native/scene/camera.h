// Perspective camera with Blender's conventions: looks down its local -Z with +Y up,
// field of view on the axis chosen by the sensor fit, optional thin lens.
#pragma once

#include "core/math.h"

namespace gp {

enum class SensorFit { Auto, Horizontal, Vertical };

struct Camera {
  Transform camera_to_world;
  float fov_degrees = 40.0f;  // full angle on the fitted axis
  SensorFit sensor_fit = SensorFit::Auto;
  int width = 256, height = 256;
  float aperture_radius = 0.0f;  // metres; 0 = pinhole
  float focus_distance = 1.0f;   // metres along the view axis

  // Ray through film position (x, y) in pixels (0,0 = top-left corner of the image) with
  // lens sample u_lens in [0,1)^2. Direction is normalised.
  Ray generate_ray(Vec2 film, Vec2 u_lens) const;
  // Half-extents of the image plane at distance 1 (tan of the half angles).
  Vec2 tan_half_extent() const;
  Vec3 position() const { return camera_to_world.point({0, 0, 0}); }
};

}  // namespace gp
