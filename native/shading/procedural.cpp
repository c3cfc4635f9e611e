#include "shading/procedural.h"

#include <algorithm>
#include <cmath>

#include "shading/hash.h"

namespace gp::shading {

namespace {

constexpr float kPiF = 3.14159265358979323846f;

// ---- Perlin noise (kernel/svm/noise.h, the non-SSE formulas) ----

float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
float negate_if(float v, uint32_t c) { return c ? -v : v; }
float lerp(float a, float b, float t) { return (1.0f - t) * a + t * b; }
float floorfrac(float x, int* i) {
  const float f = std::floor(x);
  *i = static_cast<int>(f);
  return x - f;
}

float grad1(uint32_t hash, float x) {
  const uint32_t h = hash & 15;
  const float g = static_cast<float>(1 + (h & 7));
  return negate_if(g, h & 8) * x;
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

float perlin_1d(float x) {
  int X;
  const float fx = floorfrac(x, &X);
  return lerp(grad1(hash_uint(X), fx), grad1(hash_uint(X + 1), fx - 1.0f), fade(fx));
}
float bi_mix(float v0, float v1, float v2, float v3, float x, float y) {
  const float x1 = 1.0f - x;
  return (1.0f - y) * (v0 * x1 + v1 * x) + y * (v2 * x1 + v3 * x);
}
float tri_mix(const float* v, float x, float y, float z) {
  const float x1 = 1.0f - x, y1 = 1.0f - y, z1 = 1.0f - z;
  return z1 * (y1 * (v[0] * x1 + v[1] * x) + y * (v[2] * x1 + v[3] * x)) +
         z * (y1 * (v[4] * x1 + v[5] * x) + y * (v[6] * x1 + v[7] * x));
}
float perlin_2d(float x, float y) {
  int X, Y;
  const float fx = floorfrac(x, &X), fy = floorfrac(y, &Y);
  return bi_mix(grad2(hash_uint2(X, Y), fx, fy), grad2(hash_uint2(X + 1, Y), fx - 1.0f, fy),
                grad2(hash_uint2(X, Y + 1), fx, fy - 1.0f), grad2(hash_uint2(X + 1, Y + 1), fx - 1.0f, fy - 1.0f),
                fade(fx), fade(fy));
}
float perlin_3d(float x, float y, float z) {
  int X, Y, Z;
  const float fx = floorfrac(x, &X), fy = floorfrac(y, &Y), fz = floorfrac(z, &Z);
  float v[8];
  for (int k = 0; k < 8; ++k) {
    const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
    v[k] = grad3(hash_uint3(X + dx, Y + dy, Z + dz), fx - dx, fy - dy, fz - dz);
  }
  return tri_mix(v, fade(fx), fade(fy), fade(fz));
}
float perlin_4d(float x, float y, float z, float w) {
  int X, Y, Z, W;
  const float fx = floorfrac(x, &X), fy = floorfrac(y, &Y), fz = floorfrac(z, &Z), fw = floorfrac(w, &W);
  float v[16];
  for (int k = 0; k < 16; ++k) {
    const int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1, dw = (k >> 3) & 1;
    v[k] = grad4(hash_uint4(X + dx, Y + dy, Z + dz, W + dw), fx - dx, fy - dy, fz - dz, fw - dw);
  }
  const float u = fade(fx), vv = fade(fy), t = fade(fz);
  return lerp(tri_mix(v, u, vv, t), tri_mix(v + 8, u, vv, t), fade(fw));
}

float ensure_finite(float v) { return std::isfinite(v) ? v : 0.0f; }

Vec4 scaled(const Vec4& p, float s) {
  Vec4 r;
  for (int i = 0; i < 4; ++i) r[i] = p[i] * s;
  return r;
}
Vec4 added(const Vec4& p, const Vec4& q) {
  Vec4 r;
  for (int i = 0; i < 4; ++i) r[i] = p[i] + q[i];
  return r;
}

// noisetex.h's seeds: offsets in [100, 200] that decorrelate the distortion and colour channels.
Vec4 random_offset(float seed, int dims) {
  Vec4 r;
  if (dims == 1) {
    r[0] = 100.0f + hash_float_to_float(seed) * 100.0f;
  } else {
    for (int i = 0; i < dims; ++i) r[i] = 100.0f + hash_float2_to_float(seed, static_cast<float>(i)) * 100.0f;
  }
  return r;
}

}  // namespace

float snoise(const Vec4& p, int dims) {
  switch (dims) {
    case 1: return 0.2500f * ensure_finite(perlin_1d(p[0]));
    case 2: return 0.6616f * ensure_finite(perlin_2d(p[0], p[1]));
    case 3: return 0.9820f * ensure_finite(perlin_3d(p[0], p[1], p[2]));
    default: return 0.8344f * ensure_finite(perlin_4d(p[0], p[1], p[2], p[3]));
  }
}

// Cycles 3.4's fractal_noise_Nd: octaves clamped to [0, 16], roughness to [0, 1].
float fractal_noise(const Vec4& p, int dims, float octaves, float roughness) {
  float fscale = 1.0f, amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
  octaves = std::clamp(octaves, 0.0f, 16.0f);
  roughness = std::clamp(roughness, 0.0f, 1.0f);
  const int n = static_cast<int>(octaves);
  for (int i = 0; i <= n; ++i) {
    const float t = unoise(scaled(p, fscale), dims);
    sum += t * amp;
    maxamp += amp;
    amp *= roughness;
    fscale *= 2.0f;
  }
  const float rmd = octaves - std::floor(octaves);
  if (rmd != 0.0f) {
    const float t = unoise(scaled(p, fscale), dims);
    const float sum2 = (sum + t * amp) / (maxamp + amp);
    return (1.0f - rmd) * (sum / maxamp) + rmd * sum2;
  }
  return sum / maxamp;
}

void noise_texture(const Vec4& co, int dims, float detail, float roughness, float distortion, bool want_color,
                   float* value, Vec3* color) {
  Vec4 p = co;
  if (distortion != 0.0f) {
    Vec4 d;
    for (int i = 0; i < dims; ++i) d[i] = snoise(added(p, random_offset(static_cast<float>(i), dims)), dims) * distortion;
    p = added(p, d);
  }
  *value = fractal_noise(p, dims, detail, roughness);
  if (want_color) {
    // Colour channels 2 and 3 at the seeds after the distortion's (noisetex.h).
    const float s = static_cast<float>(dims == 1 ? 1 : dims);
    *color = Vec3(*value, fractal_noise(added(p, random_offset(s, dims)), dims, detail, roughness),
                  fractal_noise(added(p, random_offset(s + 1.0f, dims)), dims, detail, roughness));
  }
}

float musgrave(MusgraveType type, const Vec4& co, int dims, float H, float lacunarity, float octaves, float offset,
               float gain) {
  Vec4 p = co;
  const float pwHL = std::pow(lacunarity, -H);
  const int n = static_cast<int>(octaves);
  const float rmd = octaves - std::floor(octaves);
  switch (type) {
    case MusgraveType::FBM: {
      float value = 0.0f, pwr = 1.0f;
      for (int i = 0; i < n; ++i) {
        value += snoise(p, dims) * pwr;
        pwr *= pwHL;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f) value += rmd * snoise(p, dims) * pwr;
      return value;
    }
    case MusgraveType::MultiFractal: {
      float value = 1.0f, pwr = 1.0f;
      for (int i = 0; i < n; ++i) {
        value *= (pwr * snoise(p, dims) + 1.0f);
        pwr *= pwHL;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f) value *= (rmd * pwr * snoise(p, dims) + 1.0f);
      return value;
    }
    case MusgraveType::HeteroTerrain: {
      float pwr = pwHL;
      float value = offset + snoise(p, dims);
      p = scaled(p, lacunarity);
      for (int i = 1; i < n; ++i) {
        value += (snoise(p, dims) + offset) * pwr * value;
        pwr *= pwHL;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f) value += rmd * ((snoise(p, dims) + offset) * pwr * value);
      return value;
    }
    case MusgraveType::HybridMultiFractal: {
      float pwr = pwHL;
      float value = snoise(p, dims) + offset;
      float weight = gain * value;
      p = scaled(p, lacunarity);
      for (int i = 1; weight > 0.001f && i < n; ++i) {
        weight = std::min(weight, 1.0f);
        const float signal = (snoise(p, dims) + offset) * pwr;
        pwr *= pwHL;
        value += weight * signal;
        weight *= gain * signal;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f && weight > 0.001f) {
        weight = std::min(weight, 1.0f);
        value += rmd * weight * ((snoise(p, dims) + offset) * pwr);
      }
      return value;
    }
    case MusgraveType::RidgedMultiFractal: {
      float pwr = pwHL;
      float signal = offset - std::abs(snoise(p, dims));
      signal *= signal;
      float value = signal;
      for (int i = 1; i < n; ++i) {
        p = scaled(p, lacunarity);
        const float weight = std::clamp(signal * gain, 0.0f, 1.0f);
        signal = offset - std::abs(snoise(p, dims));
        signal *= signal;
        signal *= weight;
        value += signal * pwr;
        pwr *= pwHL;
      }
      return value;
    }
  }
  return 0.0f;
}

// ---- Voronoi (voronoi.h), one template over 1 to 4 dimensions ----

namespace {

template <int N>
struct VP {
  float v[N];
  float& operator[](int i) { return v[i]; }
  float operator[](int i) const { return v[i]; }
  VP operator+(const VP& o) const { VP r; for (int i = 0; i < N; ++i) r[i] = v[i] + o[i]; return r; }
  VP operator-(const VP& o) const { VP r; for (int i = 0; i < N; ++i) r[i] = v[i] - o[i]; return r; }
  VP operator*(float s) const { VP r; for (int i = 0; i < N; ++i) r[i] = v[i] * s; return r; }
};
template <int N>
float vdot(const VP<N>& a, const VP<N>& b) {
  float s = 0;
  for (int i = 0; i < N; ++i) s += a[i] * b[i];
  return s;
}
template <int N>
float vlen(const VP<N>& a) { return std::sqrt(vdot(a, a)); }
template <int N>
VP<N> vmix(const VP<N>& a, const VP<N>& b, float t) { return a * (1.0f - t) + b * t; }

// The cell's feature point in [0, 1)^N (hash_floatN_to_floatN).
template <int N>
VP<N> cell_hash(const VP<N>& k) {
  VP<N> r;
  if constexpr (N == 1) r[0] = hash_float_to_float(k[0]);
  else if constexpr (N == 2) {
    r[0] = hash_float2_to_float(k[0], k[1]);
    r[1] = hash_float3_to_float(k[0], k[1], 1.0f);
  } else if constexpr (N == 3) {
    const Vec3 h = hash_float3_to_float3(Vec3(k[0], k[1], k[2]));
    r[0] = h.x, r[1] = h.y, r[2] = h.z;
  } else {
    r[0] = hash_float4_to_float(k[0], k[1], k[2], k[3]);
    r[1] = hash_float4_to_float(k[3], k[0], k[1], k[2]);
    r[2] = hash_float4_to_float(k[2], k[3], k[0], k[1]);
    r[3] = hash_float4_to_float(k[1], k[2], k[3], k[0]);
  }
  return r;
}
template <int N>
Vec3 cell_color(const VP<N>& k) {
  if constexpr (N == 1) return hash_float_to_float3(k[0]);
  else if constexpr (N == 2) return hash_float2_to_float3(k[0], k[1]);
  else if constexpr (N == 3) return hash_float3_to_float3(Vec3(k[0], k[1], k[2]));
  else return hash_float4_to_float3(k[0], k[1], k[2], k[3]);
}
template <int N>
float metric_distance(const VP<N>& a, const VP<N>& b, VoronoiMetric metric, float exponent) {
  if constexpr (N == 1) return std::abs(b[0] - a[0]);
  else {
    switch (metric) {
      case VoronoiMetric::Euclidean: return vlen(a - b);
      case VoronoiMetric::Manhattan: {
        float s = 0;
        for (int i = 0; i < N; ++i) s += std::abs(a[i] - b[i]);
        return s;
      }
      case VoronoiMetric::Chebychev: {
        float s = 0;
        for (int i = 0; i < N; ++i) s = std::max(s, std::abs(a[i] - b[i]));
        return s;
      }
      case VoronoiMetric::Minkowski: {
        float s = 0;
        for (int i = 0; i < N; ++i) s += std::pow(std::abs(a[i] - b[i]), exponent);
        return std::pow(s, 1.0f / exponent);
      }
    }
    return 0.0f;
  }
}

// Cells offset by -r..r in every dimension, x varying fastest (Cycles' loop nesting: the last
// dimension outermost), which decides ties and the order smooth F1 blends in.
template <int N, typename F>
void for_cells(int r, F&& f) {
  const int w = 2 * r + 1;
  int total = 1;
  for (int i = 0; i < N; ++i) total *= w;
  for (int idx = 0; idx < total; ++idx) {
    VP<N> o;
    int rest = idx;
    for (int i = 0; i < N; ++i) {
      o[i] = static_cast<float>(rest % w - r);
      rest /= w;
    }
    f(o);
  }
}

float smoothstep01(float x) {  // Cycles' smoothstep(0, 1, x)
  if (x < 0.0f) return 0.0f;
  if (x >= 1.0f) return 1.0f;
  return (3.0f - 2.0f * x) * x * x;
}

template <int N>
VoronoiOut voronoi_n(VoronoiFeature feature, VoronoiMetric metric, const Vec4& p4, float smoothness, float exponent,
                     float randomness) {
  VP<N> coord, cell, local;
  for (int i = 0; i < N; ++i) {
    coord[i] = p4[i];
    cell[i] = std::floor(coord[i]);
    local[i] = coord[i] - cell[i];
  }
  VoronoiOut out;
  auto point_in = [&](const VP<N>& offset) { return offset + cell_hash(cell + offset) * randomness; };
  auto set_position = [&](const VP<N>& pos) {
    for (int i = 0; i < N; ++i) out.position[i] = pos[i];
  };
  switch (feature) {
    case VoronoiFeature::F1: {
      float min_d = 8.0f;
      VP<N> target_offset{}, target_pos{};
      for_cells<N>(1, [&](const VP<N>& o) {
        const VP<N> pp = point_in(o);
        const float d = metric_distance(pp, local, metric, exponent);
        if (d < min_d) target_offset = o, min_d = d, target_pos = pp;
      });
      out.distance = min_d;
      out.color = cell_color(cell + target_offset);
      set_position(target_pos + cell);
      break;
    }
    case VoronoiFeature::SmoothF1: {
      float smooth_d = 8.0f;
      Vec3 smooth_color;
      VP<N> smooth_pos{};
      for_cells<N>(2, [&](const VP<N>& o) {
        const VP<N> pp = point_in(o);
        const float d = metric_distance(pp, local, metric, exponent);
        const float h = smoothstep01(0.5f + 0.5f * (smooth_d - d) / smoothness);
        float correction = smoothness * h * (1.0f - h);
        smooth_d = lerp(smooth_d, d, h) - correction;
        correction /= 1.0f + 3.0f * smoothness;
        const Vec3 c = cell_color(cell + o);
        smooth_color = smooth_color * (1.0f - h) + c * h - Vec3(correction);
        VP<N> corr;
        for (int i = 0; i < N; ++i) corr[i] = correction;
        smooth_pos = vmix(smooth_pos, pp, h) - corr;
      });
      out.distance = smooth_d;
      out.color = smooth_color;
      set_position(cell + smooth_pos);
      break;
    }
    case VoronoiFeature::F2: {
      float d1 = 8.0f, d2 = 8.0f;
      VP<N> off1{}, pos1{}, off2{}, pos2{};
      for_cells<N>(1, [&](const VP<N>& o) {
        const VP<N> pp = point_in(o);
        const float d = metric_distance(pp, local, metric, exponent);
        if (d < d1) {
          d2 = d1, d1 = d, off2 = off1, off1 = o, pos2 = pos1, pos1 = pp;
        } else if (d < d2) {
          d2 = d, off2 = o, pos2 = pp;
        }
      });
      out.distance = d2;
      out.color = cell_color(cell + off2);
      set_position(pos2 + cell);
      break;
    }
    case VoronoiFeature::DistanceToEdge: {
      if constexpr (N == 1) {
        const float mid = cell_hash(cell)[0] * randomness;
        VP<1> cl, cr;
        cl[0] = cell[0] - 1.0f, cr[0] = cell[0] + 1.0f;
        const float left = -1.0f + cell_hash(cl)[0] * randomness;
        const float right = 1.0f + cell_hash(cr)[0] * randomness;
        out.distance = std::min(std::abs((mid + left) / 2.0f - local[0]), std::abs((mid + right) / 2.0f - local[0]));
      } else {
        VP<N> to_closest{};
        float min_d = 8.0f;
        for_cells<N>(1, [&](const VP<N>& o) {
          const VP<N> v = point_in(o) - local;
          const float d = vdot(v, v);
          if (d < min_d) min_d = d, to_closest = v;
        });
        min_d = 8.0f;
        for_cells<N>(1, [&](const VP<N>& o) {
          const VP<N> v = point_in(o) - local;
          const VP<N> perp = v - to_closest;
          if (vdot(perp, perp) > 0.0001f) {
            const float d = vdot((to_closest + v) * 0.5f, perp * (1.0f / vlen(perp)));
            min_d = std::min(min_d, d);
          }
        });
        out.distance = min_d;
      }
      break;
    }
    case VoronoiFeature::NSphereRadius: {
      VP<N> closest{}, closest_offset{};
      float min_d = 8.0f;
      for_cells<N>(1, [&](const VP<N>& o) {
        const VP<N> pp = point_in(o);
        const float d = vlen(pp - local);
        if (d < min_d) min_d = d, closest = pp, closest_offset = o;
      });
      min_d = 8.0f;
      VP<N> closest_to_closest{};
      for_cells<N>(1, [&](const VP<N>& o) {
        bool centre = true;
        for (int i = 0; i < N; ++i) centre = centre && o[i] == 0.0f;
        if (centre) return;
        const VP<N> off = o + closest_offset;
        const VP<N> pp = off + cell_hash(cell + off) * randomness;
        const float d = vlen(closest - pp);
        if (d < min_d) min_d = d, closest_to_closest = pp;
      });
      out.radius = vlen(closest_to_closest - closest) / 2.0f;
      break;
    }
  }
  return out;
}

}  // namespace

VoronoiOut voronoi(VoronoiFeature feature, VoronoiMetric metric, const Vec4& p, int dims, float smoothness,
                   float exponent, float randomness) {
  switch (dims) {
    case 1: return voronoi_n<1>(feature, metric, p, smoothness, exponent, randomness);
    case 2: return voronoi_n<2>(feature, metric, p, smoothness, exponent, randomness);
    case 3: return voronoi_n<3>(feature, metric, p, smoothness, exponent, randomness);
    default: return voronoi_n<4>(feature, metric, p, smoothness, exponent, randomness);
  }
}

// ---- Wave, Magic, Gradient, Checker, Brick, White Noise ----

float wave(WaveType type, WaveDirection bands_dir, WaveDirection rings_dir, WaveProfile profile, Vec3 p,
           float distortion, float detail, float detail_scale, float detail_roughness, float phase) {
  // wave.h: nudged off integer lattice planes as Cycles does.
  p = (p + Vec3(0.000001f)) * 0.999999f;
  float n;
  if (type == WaveType::Bands) {
    switch (bands_dir) {
      case WaveDirection::X: n = p.x * 20.0f; break;
      case WaveDirection::Y: n = p.y * 20.0f; break;
      case WaveDirection::Z: n = p.z * 20.0f; break;
      default: n = (p.x + p.y + p.z) * 10.0f; break;
    }
  } else {
    Vec3 rp = p;
    switch (rings_dir) {
      case WaveDirection::X: rp.x = 0; break;
      case WaveDirection::Y: rp.y = 0; break;
      case WaveDirection::Z: rp.z = 0; break;
      default: break;
    }
    n = std::sqrt(dot(rp, rp)) * 20.0f;
  }
  n += phase;
  if (distortion != 0.0f) {
    Vec4 q;
    q[0] = p.x * detail_scale, q[1] = p.y * detail_scale, q[2] = p.z * detail_scale;
    n += distortion * (fractal_noise(q, 3, detail, detail_roughness) * 2.0f - 1.0f);
  }
  switch (profile) {
    case WaveProfile::Saw: {
      n /= 2.0f * kPiF;
      return n - std::floor(n);
    }
    case WaveProfile::Tri: {
      n /= 2.0f * kPiF;
      return std::abs(n - std::floor(n + 0.5f)) * 2.0f;
    }
    default: return 0.5f + 0.5f * std::sin(n - kPiF / 2.0f);
  }
}

Vec3 magic(Vec3 p, int n, float d) {
  // magic.h (3.4: the coordinate already scaled, no period wrap).
  float x = std::sin((p.x + p.y + p.z) * 5.0f);
  float y = std::cos((-p.x + p.y - p.z) * 5.0f);
  float z = -std::cos((-p.x - p.y + p.z) * 5.0f);
  if (n > 0) {
    x *= d, y *= d, z *= d;
    y = -std::cos(x - y + z) * d;
    if (n > 1) {
      x = std::cos(x - y - z) * d;
      if (n > 2) {
        z = std::sin(-x - y - z) * d;
        if (n > 3) {
          x = -std::cos(-x + y - z) * d;
          if (n > 4) {
            y = -std::sin(-x + y + z) * d;
            if (n > 5) {
              y = -std::cos(-x + y + z) * d;
              if (n > 6) {
                x = std::cos(x + y + z) * d;
                if (n > 7) {
                  z = std::sin(x + y - z) * d;
                  if (n > 8) {
                    x = -std::cos(-x - y + z) * d;
                    if (n > 9) y = -std::sin(x - y + z) * d;
                  }
                }
              }
            }
          }
        }
      }
    }
  }
  if (d != 0.0f) {
    d *= 2.0f;
    x /= d, y /= d, z /= d;
  }
  return {0.5f - x, 0.5f - y, 0.5f - z};
}

float gradient(GradientType type, Vec3 p) {
  switch (type) {
    case GradientType::Linear: return p.x;
    case GradientType::Quadratic: {
      const float r = std::max(p.x, 0.0f);
      return r * r;
    }
    case GradientType::Easing: {
      const float r = std::min(std::max(p.x, 0.0f), 1.0f);
      const float t = r * r;
      return 3.0f * t - 2.0f * t * r;
    }
    case GradientType::Diagonal: return (p.x + p.y) * 0.5f;
    case GradientType::Radial: return std::atan2(p.y, p.x) / (2.0f * kPiF) + 0.5f;
    case GradientType::QuadraticSphere: {
      const float r = std::max(0.999999f - std::sqrt(dot(p, p)), 0.0f);
      return r * r;
    }
    case GradientType::Spherical: return std::max(0.999999f - std::sqrt(dot(p, p)), 0.0f);
  }
  return 0.0f;
}

float checker(Vec3 p) {
  // checker.h: nudged so faces on integer planes do not flicker between squares.
  p.x = (p.x + 0.000001f) * 0.999999f;
  p.y = (p.y + 0.000001f) * 0.999999f;
  p.z = (p.z + 0.000001f) * 0.999999f;
  const int xi = std::abs(static_cast<int>(std::floor(p.x)));
  const int yi = std::abs(static_cast<int>(std::floor(p.y)));
  const int zi = std::abs(static_cast<int>(std::floor(p.z)));
  return ((xi % 2 == yi % 2) == static_cast<bool>(zi % 2)) ? 1.0f : 0.0f;
}

namespace {
float brick_noise(uint32_t n) {  // brick.h's integer noise
  n = (n + 1013) & 0x7fffffff;
  n = (n >> 13) ^ n;
  const uint32_t nn = (n * (n * n * 60493 + 19990303) + 1376312589) & 0x7fffffff;
  return 0.5f * (static_cast<float>(nn) / 1073741824.0f);
}
}  // namespace

void brick(Vec3 p, float mortar_size, float mortar_smooth, float bias, float brick_width, float row_height,
           float offset_amount, int offset_frequency, float squash_amount, int squash_frequency, float* tint,
           float* mortar) {
  const int rownum = static_cast<int>(std::floor(p.y / row_height));
  float offset = 0.0f;
  if (offset_frequency && squash_frequency) {
    brick_width *= (rownum % squash_frequency) ? 1.0f : squash_amount;
    offset = (rownum % offset_frequency) ? 0.0f : (brick_width * offset_amount);
  }
  const int bricknum = static_cast<int>(std::floor((p.x + offset) / brick_width));
  const float x = (p.x + offset) - brick_width * bricknum;
  const float y = p.y - row_height * rownum;
  *tint = std::clamp(brick_noise((static_cast<uint32_t>(rownum) << 16) + (bricknum & 0xFFFF)) + bias, 0.0f, 1.0f);
  float min_dist = std::min(std::min(x, y), std::min(brick_width - x, row_height - y));
  if (min_dist >= mortar_size) {
    *mortar = 0.0f;
  } else if (mortar_smooth == 0.0f) {
    *mortar = 1.0f;
  } else {
    min_dist = 1.0f - min_dist / mortar_size;
    *mortar = smoothstep01(min_dist / mortar_smooth);
  }
}

void white_noise(const Vec4& p, int dims, float* value, Vec3* color) {
  switch (dims) {
    case 1:
      *value = hash_float_to_float(p[0]);
      *color = hash_float_to_float3(p[0]);
      break;
    case 2:
      *value = hash_float2_to_float(p[0], p[1]);
      *color = hash_float2_to_float3(p[0], p[1]);
      break;
    case 3:
      *value = hash_float3_to_float(p[0], p[1], p[2]);
      *color = hash_float3_to_float3(Vec3(p[0], p[1], p[2]));
      break;
    default:
      *value = hash_float4_to_float(p[0], p[1], p[2], p[3]);
      *color = hash_float4_to_float3(p[0], p[1], p[2], p[3]);
      break;
  }
}

}  // namespace gp::shading
