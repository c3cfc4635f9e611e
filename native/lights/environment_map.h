// Image-based lighting: the World's Environment Texture as a light. An equirectangular or
// mirror-ball float image, looked up in Cycles' orientation and filtering, under the World's
// Mapping transform and strength, importance-sampled by a piecewise-constant 2D distribution
// over the map's luminance times sin(theta) (PBR 3rd ed. §14.2.4), its density per solid angle.
//
// The image (texture store) and the sampling structure (a cache keyed by image, projection,
// filter and resolution) are shared: a World edit that only turns or scales the map (the
// rendered viewport, Persistent Data) builds a new EnvironmentMap in microseconds, reusing both.
#pragma once

#include <memory>
#include <string>

#include "core/color.h"
#include "core/math.h"
#include "core/sampling.h"
#include "lights/background.h"
#include "textures/texture.h"

namespace gp {

enum class EnvProjection { Equirectangular, MirrorBall };

struct EnvironmentMapOptions {
  EnvProjection projection = EnvProjection::Equirectangular;
  // Linear, Closest, or Cubic (Cycles' Cubic and, on its CPU kernel, Smart).
  TextureFilter filter = TextureFilter::Linear;
  // The texture's vector from a world direction (the Texture Coordinate -> Mapping chain): its
  // linear 3x3 part; Cycles normalises the vector before projecting (svm_node_tex_environment).
  float to_map[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  RGB scale{1.0f};  // Background colour factor x strength
  // World > Settings > Sampling: Auto (0 x 0: the image's own size, as Cycles' light manager
  // takes its environment textures' size) or Manual (map_resolution x map_resolution / 2).
  int sampling_width = 0, sampling_height = 0;
};

// The sampling distribution of one image under one projection and filter, at one resolution,
// in the map's own frame (a rotation moves directions, not the distribution).
struct EnvironmentSampling;

class EnvironmentMap final : public BackgroundTerm {
 public:
  // Throws std::invalid_argument for a singular or non-finite transform.
  EnvironmentMap(std::shared_ptr<const TextureImage> image, const EnvironmentMapOptions& options);
  ~EnvironmentMap() override;

  // Radiance arriving from world direction `dir` (unit), strength included.
  RGB eval(const Vec3& dir) const override;
  // A direction towards the environment drawn from the map's distribution, with its density
  // per solid angle (> 0), or false (a mirror-ball sample outside the ball).
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override;
  // The density sample() gives unit world direction `dir`, per solid angle.
  float pdf(const Vec3& dir) const override;
  // The radiance at the image point sample() drew (no projection back from the direction).
  bool sample_eval(Vec2 u, Vec3* dir, float* pdf, RGB* radiance) const override;
  // eval and pdf from one projection of `dir` (the same values as each alone).
  RGB eval_pdf(const Vec3& dir, const RayState& ray, float* pdf) const override;
  // Integral of the radiance over the sphere (W m^-2 sr^-1 x sr), of the map in its own frame
  // times scale: the light's power, for light selection.
  RGB integral() const override;
  std::string identity() const override;
  const TextureImage& image() const { return *image_; }
  const std::shared_ptr<const TextureImage>& image_ptr() const { return image_; }
  const EnvironmentMapOptions& options() const { return options_; }
  int sampling_width() const;
  int sampling_height() const;
  size_t sampling_bytes() const;

  // Cycles' projections of a unit vector of the map's frame to image uv (kernel/camera/
  // projection.h): equirectangular u = 1/2 - atan2(y, x) / 2pi, v = 1 - acos(z) / pi (+Z up, +X
  // at the image's centre); mirror ball, the ball seen from -Y.
  static Vec2 equirectangular_uv(const Vec3& m);
  static Vec3 equirectangular_direction(Vec2 uv);
  static Vec2 mirror_ball_uv(const Vec3& m);
  static Vec3 mirror_ball_direction(Vec2 uv);  // zero outside the ball

 private:
  Vec3 map_vector(const Vec3& d) const;  // to_map d
  // Where unit world direction `dir` falls: its image uv, the solid angle per unit uv area
  // there (jac) and |to_map dir| (len); false for a degenerate direction.
  bool project(const Vec3& dir, Vec2* uv, float* jac, float* len) const;
  RGB radiance_at(Vec2 uv) const;                         // the filtered image x scale, non-finite as 0
  float density_at(Vec2 uv, float jac, float len) const;  // pdf() from project()'s values
  // sample()'s body: the direction, its density, and the image point it came from.
  bool sample_uv(Vec2 u, Vec3* dir, float* pdf, Vec2* uv) const;
  std::shared_ptr<const TextureImage> image_;
  EnvironmentMapOptions options_;
  float from_map_[3][3];  // inverse of to_map
  float det_ = 1.0f;      // |det to_map|
  std::shared_ptr<const EnvironmentSampling> sampling_;
};

// Number of sampling structures alive in the shared cache (tests: "built once").
size_t environment_sampling_cache_size();

}  // namespace gp
