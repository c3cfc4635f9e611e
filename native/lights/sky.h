// The World's Sky Texture as Blender 3.4 / Cycles 3.4 define it, as a light sampled like an
// image World (background.h):
//  - Nishita (Blender 3.4's default): single scattering in a spherical atmosphere (Rayleigh,
//    Mie and ozone, each with its density factor; the viewer's altitude; the sun's elevation,
//    rotation, size and intensity), precomputed into a 512 x 128 XYZ image as Cycles' SkyLoader
//    does (intern/sky/source/sky_nishita.cpp: latitude growing as the square of the row, the
//    sky mirrored about the sun's azimuth) and read back as Cycles' kernel/svm/sky.h reads it
//    (bilinear, clamped to the edge; below the horizon the horizon's row fading to black at
//    z = -0.4); the sun disc from the sun's light at the bottom and the top of its disc, with
//    limb darkening 0.6;
//  - Preetham (A. J. Preetham, P. Shirley, B. Smits, "A Practical Analytic Model for
//    Daylight", SIGGRAPH 1999): the Perez distribution with the paper's turbidity fits, zenith
//    luminance scaled by 0.06 as Cycles (scene/shader_nodes.cpp, sky_texture_precompute_
//    preetham), theta clamped just above the horizon;
//  - Hosek-Wilkie needs the authors' fitted tables, which no Debian package ships: the loader
//    renders it as Preetham (same sun direction and turbidity) with one warning.
// Radiance XYZ -> linear Rec.709 through Blender 3.4's XYZ role (the inverse of its
// srgb_to_xyz.spimtx, D65), negative components clipped.
//
// Sampling: a piecewise-constant distribution over an equirectangular grid of the sky's
// luminance x sin(theta) (cells floored at 1e-3 of the mean so every direction the sky lights
// has density), and for Nishita's sun disc a uniform cone over the disc; the two mixed in
// proportion to their power (one-sample MIS, as background.h's sum).
#pragma once

#include <memory>
#include <vector>

#include "core/color.h"
#include "core/math.h"
#include "core/sampling.h"
#include "lights/background.h"

namespace gp {

enum class SkyModel { Nishita, Preetham };

// Blender 3.4's Sky Texture node settings and defaults (angles in radians, altitude in metres).
struct SkyOptions {
  SkyModel model = SkyModel::Nishita;
  bool sun_disc = true;
  float sun_size = 0.009512f;  // angular diameter
  float sun_intensity = 1.0f;
  float sun_elevation = 0.2617994f;  // 15 degrees
  float sun_rotation = 0.0f;
  float altitude = 0.0f;
  float air_density = 1.0f, dust_density = 1.0f, ozone_density = 1.0f;
  Vec3 sun_direction{0, 0, 1};  // Preetham
  float turbidity = 2.2f;       // Preetham
  RGB scale{1.0f};              // Background colour factor x strength
};

class SkyTexture final : public BackgroundTerm {
 public:
  // Throws std::invalid_argument for settings that are not finite. `threads` (0: all) builds
  // the image and grid; any count gives the same bits (each texel and cell is computed alone).
  explicit SkyTexture(const SkyOptions& options, int threads = 0);
  RGB eval(const Vec3& dir) const override;
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override;
  float pdf(const Vec3& dir) const override;
  RGB integral() const override { return (sky_.integral + sun_integral_) * options_.scale; }
  std::string identity() const override;
  // Options with Cycles' clamps applied, and as text (the shared cache's key).
  static SkyOptions normalized(SkyOptions options);
  // Nishita's sun direction as Blender 3.4 renders it: elevation e, azimuth `rotation` from +Y
  // towards +X (radians).
  static Vec3 nishita_sun_direction(float elevation, float rotation);
  static std::string describe(const SkyOptions& options);
  const SkyOptions& options() const { return options_; }

  // Unscaled radiance of the model along unit `dir`, with or without the sun disc.
  RGB radiance(const Vec3& dir, bool with_sun) const;
  // Nishita's precomputed image (512 x 128 texels, linear Rec.709; empty for Preetham) and
  // the sun's light at the bottom and top of its disc.
  static constexpr int kNishitaWidth = 512, kNishitaHeight = 128;
  const std::vector<RGB>& nishita_texels() const { return texels_; }
  RGB sun_bottom() const { return sun_bottom_; }
  RGB sun_top() const { return sun_top_; }
  Vec3 sun_direction() const { return sun_dir_; }
  // Probability that sample() draws from the sun's cone (0 without a sun disc).
  float sun_probability() const { return p_sun_; }

 private:
  RGB nishita(const Vec3& dir, bool with_sun) const;
  RGB preetham(const Vec3& dir) const;
  RGB lookup(float x, float y) const;  // bilinear, clamped to the edge (Cycles' EXTENSION_EXTEND)
  bool in_sun(const Vec3& dir) const;
  Vec3 sample_sun(Vec2 u) const;  // uniform over the sun's cone
  void build_sampling(int threads);

  SkyOptions options_;
  // Nishita
  std::vector<RGB> texels_;
  RGB sun_bottom_, sun_top_;
  Vec3 sun_dir_;
  double sun_cos_half_ = 1, sun_one_minus_cos_ = 0;  // 1 - cos(half angle), without cancellation
  // Preetham: Perez coefficients for Y, x, y and the zenith values divided by F(0, theta_s)
  float perez_[3][5] = {};
  float zenith_[3] = {};
  float sun_theta_ = 0, sun_phi_ = 0;
  // Sampling
  BakedDirections sky_;  // the sky without its sun: its grid and integral
  float p_sun_ = 0;
  RGB sun_integral_;
};

// While one lives on a thread, Sky Textures evaluated in a node graph there leave out their sun
// disc (shading/nodes.cpp): a World graph bakes its grid without the discs it samples by their
// cones (world_graph.h).
class SkySunDiscsOff {
 public:
  SkySunDiscsOff();
  ~SkySunDiscsOff();
  SkySunDiscsOff(const SkySunDiscsOff&) = delete;
  SkySunDiscsOff& operator=(const SkySunDiscsOff&) = delete;
  static bool active();

 private:
  bool previous_;
};

// The sky of `options` (its scale ignored: wrap it in a ScaledBackground), built once and shared
// while anything holds it: the rendered viewport's World edits and a sky seen twice (camera and
// lit backgrounds) reuse the precomputation.
std::shared_ptr<const SkyTexture> shared_sky(SkyOptions options);
// Number of skies alive in the shared cache (tests: "built once").
size_t sky_cache_size();

}  // namespace gp
