// Nodes against Blender 3.4's Cycles (textures, colour, converter and vector nodes): tests/blender_refs/shading_refs.json holds
// pixels of each case of shading_cases.json rendered by Cycles (render_shading_refs.py says
// how): pixel (i, j) is the node at a constant Vector, an exact binary fraction, so both sides
// evaluate the same float point. Bound 2e-5 absolute: float rounding of Cycles' SSE code paths
// (measured worst per case is recorded); a wrong hash, octave or offset moves values by 1e-2.
// Also the hash against lookup3 as written in util/hash.h, recomputed independently in Python.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "shading/hash.h"

// The vector lanes of hash.h are inline only (no ABI crosses a call): GCC's note on 32-byte
// vectors without AVX does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"
#include "shading/procedural.h"
#include "shading_test_util.h"

namespace gp::shading {
namespace {

nlohmann::json read_json(const std::string& name) {
  std::ifstream f(std::string(GRADPHOTON_SOURCE_DIR) + "/tests/blender_refs/" + name);
  return nlohmann::json::parse(f);
}

TEST(ShadingHash, Lookup3FinalOfKnownKeys) {
  // hash_uint(0): a = b = c = 0xdeadbeef + (1 << 2) + 13, then final(a, b, c): the value below
  // was computed by a separate Python transcription of those lines.
  EXPECT_EQ(hash_uint(0u), 2501500005u);
  // Consistency of the float hashes with the integer ones.
  EXPECT_EQ(hash_float_to_float(0.0f), uint_to_float_incl(hash_uint(0u)));
  EXPECT_NE(hash_uint2(1u, 2u), hash_uint2(2u, 1u));
  EXPECT_NE(hash_uint4(1u, 2u, 3u, 4u), hash_uint4(1u, 2u, 3u, 5u));
}

// ---- Perlin noise bit for bit against a scalar transcription of kernel/svm/noise.h ----
// procedural.cpp hashes and grades a cell's corners over vector lanes; these are the non-SSE
// formulas one corner at a time. Any difference in a hash, a gradient's selection or sign, or
// the order of the additions changes some bits of some of the points below.
namespace ref {
float negate_if(float v, uint32_t c) { return c ? -v : v; }
float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
float floorfrac(float x, int* i) {
  const float f = std::floor(x);
  *i = static_cast<int>(f);
  return x - f;
}
float grad2(uint32_t hash, float x, float y) {
  const uint32_t h = hash & 7;
  const float u = h < 4 ? x : y, v = 2.0f * (h < 4 ? y : x);
  return negate_if(u, h & 1) + negate_if(v, h & 2);
}
float grad3(uint32_t hash, float x, float y, float z) {
  const uint32_t h = hash & 15;
  const float u = h < 8 ? x : y;
  const float vt = (h == 12 || h == 14) ? x : z;
  const float v = h < 4 ? y : vt;
  return negate_if(u, h & 1) + negate_if(v, h & 2);
}
float grad4(uint32_t hash, float x, float y, float z, float w) {
  const uint32_t h = hash & 31;
  const float u = h < 24 ? x : y, v = h < 16 ? y : z, s = h < 8 ? z : w;
  return negate_if(u, h & 1) + negate_if(v, h & 2) + negate_if(s, h & 4);
}
float tri_mix(const float* v, float x, float y, float z) {
  const float x1 = 1.0f - x, y1 = 1.0f - y, z1 = 1.0f - z;
  return z1 * (y1 * (v[0] * x1 + v[1] * x) + y * (v[2] * x1 + v[3] * x)) +
         z * (y1 * (v[4] * x1 + v[5] * x) + y * (v[6] * x1 + v[7] * x));
}
float perlin(const Vec4& p, int dims) {
  int X, Y, Z, W;
  const float fx = floorfrac(p[0], &X), fy = floorfrac(p[1], &Y), fz = floorfrac(p[2], &Z), fw = floorfrac(p[3], &W);
  if (dims == 2) {
    const float v0 = grad2(hash_uint2(X, Y), fx, fy), v1 = grad2(hash_uint2(X + 1, Y), fx - 1.0f, fy);
    const float v2 = grad2(hash_uint2(X, Y + 1), fx, fy - 1.0f);
    const float v3 = grad2(hash_uint2(X + 1, Y + 1), fx - 1.0f, fy - 1.0f);
    const float x = fade(fx), y = fade(fy), x1 = 1.0f - x;
    return (1.0f - y) * (v0 * x1 + v1 * x) + y * (v2 * x1 + v3 * x);
  }
  float v[16];
  for (int k = 0; k < (dims == 3 ? 8 : 16); ++k) {
    const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1, dw = (k >> 3) & 1;
    v[k] = dims == 3 ? grad3(hash_uint3(X + dx, Y + dy, Z + dz), fx - dx, fy - dy, fz - dz)
                     : grad4(hash_uint4(X + dx, Y + dy, Z + dz, W + dw), fx - dx, fy - dy, fz - dz, fw - dw);
  }
  if (dims == 3) return tri_mix(v, fade(fx), fade(fy), fade(fz));
  const float t = fade(fw);
  return (1.0f - t) * tri_mix(v, fade(fx), fade(fy), fade(fz)) + t * tri_mix(v + 8, fade(fx), fade(fy), fade(fz));
}
}  // namespace ref

TEST(ShadingProcedural, PerlinBitForBitAsTheScalarFormulas) {
  // Points over [-300, 300] (negative cells, every gradient index) and near lattice planes.
  uint64_t state = 12345;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<float>(state >> 40) / static_cast<float>(1 << 24);
  };
  const float scales[3] = {600.0f, 6.0f, 1e-3f};
  const float factors[5] = {0, 0, 0.6616f, 0.9820f, 0.8344f};  // snoise_Nd's
  for (int dims = 2; dims <= 4; ++dims)
    for (int i = 0; i < 30000; ++i) {
      Vec4 p;
      const float s = scales[i % 3];
      for (int k = 0; k < dims; ++k) p[k] = (next() - 0.5f) * s + (i % 3 == 2 ? std::round(next() * 20.0f) : 0.0f);
      const float expected = factors[dims] * ref::perlin(p, dims);
      const float got = snoise(p, dims);
      uint32_t a, b;
      std::memcpy(&a, &expected, 4);
      std::memcpy(&b, &got, 4);
      ASSERT_EQ(a, b) << dims << "D noise at (" << p[0] << ", " << p[1] << ", " << p[2] << ", " << p[3] << "): "
                      << got << " against " << expected;
    }
}

// The Noise Texture (3D) bit for bit against noisetex.h's scalar loop (a guard for any
// reordering of its fBMs' octaves or colour channels, e.g. evaluating their points together).
// Whole and fractional detail (a last, partial octave), roughness, distortion, a NaN detail,
// and points far out (cells of 2^20).
namespace ref {
float unoise3(const Vec4& p) {
  const float v = perlin(p, 3);
  return 0.5f * (0.9820f * (std::isfinite(v) ? v : 0.0f)) + 0.5f;
}
float fractal3(const Vec4& p, float octaves, float roughness) {  // fractal_noise_3d
  float fscale = 1.0f, amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
  octaves = std::clamp(octaves, 0.0f, 16.0f);
  roughness = std::clamp(roughness, 0.0f, 1.0f);
  const int n = static_cast<int>(octaves);
  for (int i = 0; i <= n; ++i) {
    Vec4 q;
    for (int k = 0; k < 4; ++k) q[k] = p[k] * fscale;
    sum += unoise3(q) * amp;
    maxamp += amp;
    amp *= roughness;
    fscale *= 2.0f;
  }
  const float rmd = octaves - std::floor(octaves);
  if (rmd != 0.0f) {
    Vec4 q;
    for (int k = 0; k < 4; ++k) q[k] = p[k] * fscale;
    const float sum2 = (sum + unoise3(q) * amp) / (maxamp + amp);
    return (1.0f - rmd) * (sum / maxamp) + rmd * sum2;
  }
  return sum / maxamp;
}
Vec4 offset3(float seed) {  // noisetex.h's random_float3_offset
  Vec4 r;
  for (int i = 0; i < 3; ++i) r[i] = 100.0f + hash_float2_to_float(seed, static_cast<float>(i)) * 100.0f;
  return r;
}
Vec4 plus(const Vec4& a, const Vec4& b) {
  Vec4 r;
  for (int k = 0; k < 4; ++k) r[k] = a[k] + b[k];
  return r;
}
}  // namespace ref

TEST(ShadingProcedural, NoiseTexture3DBitForBitAsTheScalarLoop) {
  uint64_t state = 777;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<float>(state >> 40) / static_cast<float>(1 << 24);
  };
  auto bits = [](float f) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    return b;
  };
  const float details[] = {0.0f, 1.0f, 2.0f, 2.5f, 5.75f, 15.0f, 16.0f, 20.0f, std::nanf("")};
  for (int i = 0; i < 6000; ++i) {
    Vec4 p;
    const float s = i % 3 == 0 ? 2e6f : (i % 3 == 1 ? 20.0f : 1e-3f);
    for (int k = 0; k < 3; ++k) p[k] = (next() - 0.5f) * s;
    const float detail = details[i % 9], roughness = next() * 1.2f, distortion = i % 4 == 0 ? next() * 3.0f : 0.0f;
    // noisetex.h: distortion by snoise at seeded offsets, then the value and colour fBMs.
    Vec4 q = p;
    if (distortion != 0.0f) {
      Vec4 d;
      for (int k = 0; k < 3; ++k) {
        const float v = ref::perlin(ref::plus(p, ref::offset3(static_cast<float>(k))), 3);
        d[k] = 0.9820f * (std::isfinite(v) ? v : 0.0f) * distortion;
      }
      q = ref::plus(p, d);
    }
    const float ev = ref::fractal3(q, detail, roughness);
    const float eg = ref::fractal3(ref::plus(q, ref::offset3(3.0f)), detail, roughness);
    const float eb = ref::fractal3(ref::plus(q, ref::offset3(4.0f)), detail, roughness);
    float value, alone;
    Vec3 color, unused;
    noise_texture(p, 3, detail, roughness, distortion, true, &value, &color);
    noise_texture(p, 3, detail, roughness, distortion, false, &alone, &unused);
    ASSERT_EQ(bits(value), bits(ev)) << "value at (" << p[0] << ", " << p[1] << ", " << p[2] << "), detail " << detail;
    ASSERT_EQ(bits(alone), bits(ev)) << "value without colour, detail " << detail;
    ASSERT_EQ(bits(color.x), bits(ev));
    ASSERT_EQ(bits(color.y), bits(eg)) << "green at (" << p[0] << ", " << p[1] << ", " << p[2] << "), detail " << detail;
    ASSERT_EQ(bits(color.z), bits(eb)) << "blue, detail " << detail;
  }
}

// Voronoi F1 and F2 (Euclidean, Manhattan, Chebychev) bit for bit against voronoi.h's loop with
// each cell hashed and measured on its own: procedural.cpp hashes the neighbourhood and measures
// its distances over vector lanes, and reuses a 3D cell's hash as its colour (both
// hash_float3_to_float3).
TEST(ShadingProcedural, VoronoiCellHashesAsTheScalarLoop) {
  uint64_t state = 777;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<float>(state >> 40) / static_cast<float>(1 << 24);
  };
  for (int dims = 2; dims <= 4; ++dims)
    for (int i = 0; i < 3000; ++i) {
      Vec4 p;
      for (int k = 0; k < dims; ++k) p[k] = (next() - 0.5f) * 40.0f;
      const float randomness = i % 2 ? 1.0f : 0.7f;
      const VoronoiMetric metric = static_cast<VoronoiMetric>(i % 3);
      const VoronoiFeature feature = i % 4 == 3 ? VoronoiFeature::F2 : VoronoiFeature::F1;
      float cell[4], local[4];
      for (int k = 0; k < 4; ++k) cell[k] = std::floor(p[k]), local[k] = p[k] - cell[k];
      float best = 8.0f, best_pos[4] = {0, 0, 0, 0}, best_key[4] = {0, 0, 0, 0};
      float second = 8.0f, second_pos[4] = {0, 0, 0, 0}, second_key[4] = {0, 0, 0, 0};
      const int total = dims == 2 ? 9 : dims == 3 ? 27 : 81;
      for (int idx = 0; idx < total; ++idx) {
        float o[4] = {0, 0, 0, 0}, key[4], h[4], pp[4];
        for (int k = 0, rest = idx; k < dims; ++k, rest /= 3) o[k] = static_cast<float>(rest % 3 - 1);
        for (int k = 0; k < dims; ++k) key[k] = cell[k] + o[k];
        if (dims == 2) {
          h[0] = hash_float2_to_float(key[0], key[1]), h[1] = hash_float3_to_float(key[0], key[1], 1.0f);
        } else if (dims == 3) {
          const Vec3 c = hash_float3_to_float3(Vec3(key[0], key[1], key[2]));
          h[0] = c.x, h[1] = c.y, h[2] = c.z;
        } else {
          h[0] = hash_float4_to_float(key[0], key[1], key[2], key[3]);
          h[1] = hash_float4_to_float(key[3], key[0], key[1], key[2]);
          h[2] = hash_float4_to_float(key[2], key[3], key[0], key[1]);
          h[3] = hash_float4_to_float(key[1], key[2], key[3], key[0]);
        }
        float sum = 0.0f;
        for (int k = 0; k < dims; ++k) {
          pp[k] = o[k] + h[k] * randomness;
          const float t = pp[k] - local[k];
          if (metric == VoronoiMetric::Euclidean) sum += t * t;
          else if (metric == VoronoiMetric::Manhattan) sum += std::abs(t);
          else sum = std::max(sum, std::abs(t));
        }
        const float d = metric == VoronoiMetric::Euclidean ? std::sqrt(sum) : sum;
        if (d < best) {
          second = best;
          std::copy(best_pos, best_pos + 4, second_pos);
          std::copy(best_key, best_key + 4, second_key);
          best = d;
          for (int k = 0; k < dims; ++k) best_pos[k] = pp[k] + cell[k], best_key[k] = key[k];
        } else if (d < second) {
          second = d;
          for (int k = 0; k < dims; ++k) second_pos[k] = pp[k] + cell[k], second_key[k] = key[k];
        }
      }
      if (feature == VoronoiFeature::F2) {
        best = second;
        std::copy(second_pos, second_pos + 4, best_pos);
        std::copy(second_key, second_key + 4, best_key);
      }
      const Vec3 color = dims == 2   ? hash_float2_to_float3(best_key[0], best_key[1])
                         : dims == 3 ? hash_float3_to_float3(Vec3(best_key[0], best_key[1], best_key[2]))
                                     : hash_float4_to_float3(best_key[0], best_key[1], best_key[2], best_key[3]);
      const VoronoiOut o = voronoi(feature, metric, p, dims, 0.0f, 0.5f, randomness);
      ASSERT_EQ(o.distance, best) << dims << "D Voronoi at point " << i;
      for (int k = 0; k < 3; ++k) ASSERT_EQ(o.color[k], color[k]) << dims << "D Voronoi colour at point " << i;
      for (int k = 0; k < dims; ++k) ASSERT_EQ(o.position[k], best_pos[k]) << dims << "D Voronoi position at point " << i;
    }
}

// The 3D F1 Euclidean Voronoi measures the eight cells towards the point's nearest corner first
// and skips cells whose cube is farther than their least distance (procedural.cpp,
// voronoi_f1_euclidean3): against voronoi.h's loop over all 27 cells, written out here, on
// random points and on the cases that test its bound and its tie-break: randomness 0 (feature
// points on the lattice: equal distances between cells), points on the half-way planes
// (local 0.5: the block's side chosen on a tie), on cell faces, -0, and far out (cells of 2^22).
TEST(ShadingProcedural, VoronoiF1NearestCellsFirstAsTheFullLoop) {
  uint64_t state = 4242;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<float>(state >> 40) / static_cast<float>(1 << 24);
  };
  auto bits = [](float f) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    return b;
  };
  const float randomness_of[5] = {1.0f, 0.7f, 0.0f, 0.05f, 1.0f};
  for (int i = 0; i < 40000; ++i) {
    Vec4 p;
    for (int k = 0; k < 3; ++k) {
      switch ((i / 5 + k) % 6) {
        case 0: p[k] = std::floor((next() - 0.5f) * 16.0f) + 0.5f; break;  // half-way
        case 1: p[k] = std::floor((next() - 0.5f) * 16.0f); break;         // a cell face
        case 2: p[k] = -0.0f; break;
        case 3: p[k] = (next() - 0.5f) * 8388608.0f; break;                   // cells of up to 2^22
        default: p[k] = (next() - 0.5f) * 40.0f; break;
      }
    }
    const float randomness = randomness_of[i % 5];
    float cell[3], local[3];
    for (int k = 0; k < 3; ++k) cell[k] = std::floor(p[k]), local[k] = p[k] - cell[k];
    float best = 8.0f, best_pos[3] = {0, 0, 0};
    Vec3 best_color;
    for (int idx = 0; idx < 27; ++idx) {
      const float o[3] = {static_cast<float>(idx % 3 - 1), static_cast<float>(idx / 3 % 3 - 1),
                          static_cast<float>(idx / 9 - 1)};
      const Vec3 h = hash_float3_to_float3(Vec3(cell[0] + o[0], cell[1] + o[1], cell[2] + o[2]));
      float pp[3], sum = 0.0f;
      for (int k = 0; k < 3; ++k) {
        pp[k] = o[k] + h[k] * randomness;
        const float t = pp[k] - local[k];
        sum += t * t;
      }
      const float d = std::sqrt(sum);
      if (d < best) {
        best = d, best_color = h;
        for (int k = 0; k < 3; ++k) best_pos[k] = pp[k] + cell[k];
      }
    }
    const VoronoiOut o = voronoi(VoronoiFeature::F1, VoronoiMetric::Euclidean, p, 3, 0.0f, 0.5f, randomness);
    ASSERT_EQ(bits(o.distance), bits(best)) << "at (" << p[0] << ", " << p[1] << ", " << p[2] << "), randomness "
                                            << randomness;
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(bits(o.color[k]), bits(best_color[k])) << "colour at point " << i;
      ASSERT_EQ(bits(o.position[k]), bits(best_pos[k])) << "position at point " << i;
    }
  }
}

// Checker's parity test (procedural.cpp: a ^ b ^ c) against checker.h's formula as written.
TEST(ShadingProcedural, CheckerAsCyclesFormula) {
  uint64_t state = 99;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<float>(state >> 40) / static_cast<float>(1 << 24);
  };
  for (int i = 0; i < 100000; ++i) {
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = (next() - 0.5f) * (i % 2 ? 20.0f : 2e5f) + (i % 3 == 0 ? std::round(next() * 8.0f) : 0.0f);
    Vec3 q = p;
    for (int k = 0; k < 3; ++k) q[k] = (q[k] + 0.000001f) * 0.999999f;
    const int xi = std::abs(static_cast<int>(std::floor(q.x))), yi = std::abs(static_cast<int>(std::floor(q.y)));
    const int zi = std::abs(static_cast<int>(std::floor(q.z)));
    const float expected = ((xi % 2 == yi % 2) == static_cast<bool>(zi % 2)) ? 1.0f : 0.0f;
    ASSERT_EQ(checker(p), expected) << "at (" << p.x << ", " << p.y << ", " << p.z << ")";
  }
}

TEST(ShadingHash, VectorLanesAreTheScalarHashes) {
  u32x8 k[4];
  for (int j = 0; j < 4; ++j)
    for (int l = 0; l < 8; ++l) k[j][l] = 0x9E3779B9u * (8 * j + l + 1) ^ (l << 28);
  const u32x8 h1 = hash_uint_v(k[0]), h2 = hash_uint2_v(k[0], k[1]), h3 = hash_uint3_v(k[0], k[1], k[2]);
  const u32x8 h4 = hash_uint4_v(k[0], k[1], k[2], k[3]);
  const f32x8 f = uint_to_float_incl_v(h4);
  for (int l = 0; l < 8; ++l) {
    EXPECT_EQ(h1[l], hash_uint(k[0][l]));
    EXPECT_EQ(h2[l], hash_uint2(k[0][l], k[1][l]));
    EXPECT_EQ(h3[l], hash_uint3(k[0][l], k[1][l], k[2][l]));
    EXPECT_EQ(h4[l], hash_uint4(k[0][l], k[1][l], k[2][l], k[3][l]));
    EXPECT_EQ(f[l], uint_to_float_incl(h4[l]));  // the conversion's rounding too
  }
  // Conversions that round (more than 24 significant bits) and the ends.
  const u32x8 edge = {0u, 1u, 0xFFFFFFFFu, 0xFFFFFF7Fu, 0xFFFFFF80u, 0x80000001u, 0x01000001u, 0x7FFFFFC0u};
  const f32x8 fe = uint_to_float_incl_v(edge);
  for (int l = 0; l < 8; ++l) EXPECT_EQ(fe[l], uint_to_float_incl(edge[l])) << edge[l];
}

TEST(ShadingProcedural, MatchesCyclesRenders) {
  const nlohmann::json cases = read_json("shading_cases.json");
  const nlohmann::json refs = read_json("shading_refs.json");
  const int n = refs["n"].get<int>();
  const float x0 = refs["x0"].get<float>(), y0 = refs["y0"].get<float>();
  ShadingObject object;  // identity: Object coordinates are world positions
  for (const auto& c : cases) {
    const std::string name = c["name"].get<std::string>();
    nlohmann::json tex = {{"type", c["type"]}, {"props", c["props"]}, {"inputs", c["inputs"]}};
    const auto& expected = refs["cases"][name];
    // Blackbody and Wavelength: Cycles uses fitted tables, here the CIE observer directly.
    const float tol = c.contains("tol") ? c["tol"].get<float>() : 2e-5f;
    ASSERT_EQ(expected.size(), static_cast<size_t>(n * n)) << name;
    double worst = 0;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        // The point through a Combine XYZ into the input named by "vary", as the render has it.
        nlohmann::json nodes = {{"tex", tex}};
        const nlohmann::json vary = c.contains("vary") ? c["vary"] : nlohmann::json("Vector");
        if (!vary.is_null()) {
          nodes["xyz"] = {{"type", "ShaderNodeCombineXYZ"},
                          {"inputs", {{"X", x0 + (i + 0.5f) / n}, {"Y", y0 + (j + 0.5f) / n}, {"Z", 0.0f}}}};
          nodes["tex"]["inputs"][vary.get<std::string>()] = {{"link", "xyz"}, {"output", "Vector"}};
        }
        GraphCompiler g(name, nodes, nullptr);
        const int root = g.link({{"link", "tex"}, {"output", c["output"]}}, SocketType::Color);
        const auto prog = g.compile();
        ShadingContext ctx;
        ctx.object = &object;
        const Vec3 v = prog->evaluate(ctx, g.source(root));
        const auto& e = expected[j * n + i];
        for (int k = 0; k < 3; ++k) {
          worst = std::max(worst, std::abs(static_cast<double>(v[k]) - e[k].get<double>()));
          EXPECT_NEAR(v[k], e[k].get<float>(), tol) << name << " pixel (" << i << ", " << j << ") channel " << k;
        }
      }
    RecordProperty(name, std::to_string(worst));
  }
}

}  // namespace
}  // namespace gp::shading
