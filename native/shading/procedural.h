// The procedural textures of Cycles 3.4 (intern/cycles/kernel/svm/noise.h, noisetex.h,
// musgrave.h, voronoi.h, wave.h, magic.h, gradient.h, checker.h, brick.h, white_noise.h):
// the same formulas and the same hash (shading/hash.h), so values agree with Cycles' to float
// rounding. Coordinates are already multiplied by the node's Scale where Cycles does so.
#pragma once

#include "core/math.h"

namespace gp::shading {

// A point of 1 to 4 dimensions (the Noise, Musgrave, Voronoi and White Noise "dimensions").
struct Vec4 {
  float v[4] = {0, 0, 0, 0};
  float& operator[](int i) { return v[i]; }
  float operator[](int i) const { return v[i]; }
};

// Signed Perlin noise in [-1, 1] (snoise_Nd: perlin scaled by OSL's factors), unsigned in [0, 1].
float snoise(const Vec4& p, int dims);
inline float unoise(const Vec4& p, int dims) { return 0.5f * snoise(p, dims) + 0.5f; }

// Noise Texture (3.4): fBM of unsigned noise, detail octaves, roughness; distortion and the
// colour output's offsets as noisetex.h. `p` already scaled.
void noise_texture(const Vec4& p, int dims, float detail, float roughness, float distortion, bool want_color,
                   float* value, Vec3* color);

enum class MusgraveType { MultiFractal, FBM, HybridMultiFractal, RidgedMultiFractal, HeteroTerrain };
// Musgrave Texture (3.4, musgrave.h): H = Dimension, octaves = Detail. `p` already scaled.
float musgrave(MusgraveType type, const Vec4& p, int dims, float H, float lacunarity, float octaves, float offset,
               float gain);

enum class VoronoiFeature { F1, F2, SmoothF1, DistanceToEdge, NSphereRadius };
enum class VoronoiMetric { Euclidean, Manhattan, Chebychev, Minkowski };
struct VoronoiOut {
  float distance = 0;
  Vec3 color;
  Vec4 position;  // of the feature point, dims components
  float radius = 0;
};
// Voronoi Texture (3.4, voronoi.h) at scaled p; smoothness as the node passes it (already / 2,
// clamped), randomness clamped.
VoronoiOut voronoi(VoronoiFeature feature, VoronoiMetric metric, const Vec4& p, int dims, float smoothness,
                   float exponent, float randomness);

// Cycles' fractal_noise (3.4; the Wave texture's distortion): unsigned noise fBM.
float fractal_noise(const Vec4& p, int dims, float octaves, float roughness);

enum class WaveType { Bands, Rings };
enum class WaveDirection { X, Y, Z, Diagonal, Spherical };  // bands: X Y Z Diagonal; rings: X Y Z Spherical
enum class WaveProfile { Sin, Saw, Tri };
float wave(WaveType type, WaveDirection bands_dir, WaveDirection rings_dir, WaveProfile profile, Vec3 p,
           float distortion, float detail, float detail_scale, float detail_roughness, float phase);

Vec3 magic(Vec3 p, int depth, float distortion);

enum class GradientType { Linear, Quadratic, Easing, Diagonal, Radial, QuadraticSphere, Spherical };
float gradient(GradientType type, Vec3 p);

// 1 on Color1's squares, 0 on Color2's (checker.h), p already scaled.
float checker(Vec3 p);

// Brick: (tint, mortar) as brick.h.
void brick(Vec3 p, float mortar_size, float mortar_smooth, float bias, float brick_width, float row_height,
           float offset_amount, int offset_frequency, float squash_amount, int squash_frequency, float* tint,
           float* mortar);

// White Noise (white_noise.h): value and colour of the hash of p's dims components.
void white_noise(const Vec4& p, int dims, float* value, Vec3* color);

}  // namespace gp::shading
