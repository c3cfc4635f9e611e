#include "lights/environment_map.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "core/parallel.h"

namespace gp {

struct EnvironmentSampling {
  std::shared_ptr<const TextureImage> image;  // kept alive with its distribution (cache key)
  int width = 0, height = 0;
  PiecewiseConstant2D distribution;  // over image uv, in the map's frame
  RGB integral;                      // of the unscaled map over the sphere
};

namespace {

// ---- Cell weights ----

// Integral over one texel cell of the filtered image's 1D reconstruction, per texel offset:
// closest is the texel itself; linear (tent between texel centres) gives 1/8, 3/4, 1/8; Cycles'
// cubic B-spline gives 1/384, 19/96, 115/192, 19/96, 1/384 (its basis integrated over unit
// intervals). Weighting cells by these makes the density proportional to the mean of the
// filtered map over each cell, so it is non-zero wherever eval() is.
std::vector<float> cell_kernel(TextureFilter filter) {
  switch (filter) {
    case TextureFilter::Closest: return {1.0f};
    case TextureFilter::Linear: return {0.125f, 0.75f, 0.125f};
    case TextureFilter::Cubic: return {1.0f / 384, 19.0f / 96, 115.0f / 192, 19.0f / 96, 1.0f / 384};
  }
  return {1.0f};
}

// Texel luminance (negative components clipped) convolved by the kernel in x and y, wrapping
// as Cycles' environment textures do (Repeat). Also the per-row sums of the texels' RGB, for
// the integral.
std::vector<float> filtered_luminance(const TextureImage& img, TextureFilter filter, std::vector<RGB>* row_sums) {
  const int w = img.width, h = img.height;
  const size_t n = static_cast<size_t>(w) * h;
  std::vector<float> lum(n);
  row_sums->assign(h, RGB(0.0f));
  parallel_for(static_cast<size_t>(h), 0, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y != y1; ++y) {
      double sum[3] = {0, 0, 0};
      const float* p = &img.rgba[4 * y * w];
      for (int x = 0; x < w; ++x, p += 4) {
        RGB c(std::max(0.0f, p[0]), std::max(0.0f, p[1]), std::max(0.0f, p[2]));
        if (img.srgb_encoded) c = img.decoded({c, 1.0f}).rgb;
        lum[y * w + x] = c.luminance();
        for (int k = 0; k < 3; ++k) sum[k] += c[k];
      }
      (*row_sums)[y] = RGB(float(sum[0]), float(sum[1]), float(sum[2]));
    }
  });
  const std::vector<float> k = cell_kernel(filter);
  const int r = static_cast<int>(k.size()) / 2;
  if (r == 0) return lum;
  std::vector<float> tmp(n);
  // Horizontal, then vertical; indices wrapped once per axis, not per tap.
  std::vector<int> xi(w + 2 * r), yi(h + 2 * r);
  for (int i = 0; i < w + 2 * r; ++i) xi[i] = ((i - r) % w + w) % w;
  for (int i = 0; i < h + 2 * r; ++i) yi[i] = ((i - r) % h + h) % h;
  parallel_for(static_cast<size_t>(h), 0, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y != y1; ++y) {
      const float* row = &lum[y * w];
      float* out = &tmp[y * w];
      for (int x = 0; x < w; ++x) {
        float s = 0;
        for (int j = 0; j <= 2 * r; ++j) s += k[j] * row[xi[x + j]];
        out[x] = s;
      }
    }
  });
  parallel_for(static_cast<size_t>(h), 0, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y != y1; ++y) {
      float* out = &lum[y * w];
      for (int x = 0; x < w; ++x) out[x] = 0;
      for (int j = 0; j <= 2 * r; ++j) {
        const float* row = &tmp[static_cast<size_t>(yi[y + j]) * w];
        const float kj = k[j];
        for (int x = 0; x < w; ++x) out[x] += kj * row[x];
      }
    }
  });
  return lum;
}

// Fraction of the uv cell [u0,u1]x[v0,v1] inside the mirror ball (the disc of radius 1/2 at
// (1/2, 1/2)): 8 x 8 sub-samples, at least 1/64 where the cell touches the disc at all.
float mirror_ball_coverage(float u0, float u1, float v0, float v1) {
  const float nu = std::clamp(0.5f, u0, u1), nv = std::clamp(0.5f, v0, v1);
  if ((nu - 0.5f) * (nu - 0.5f) + (nv - 0.5f) * (nv - 0.5f) >= 0.25f) return 0.0f;
  int inside = 0;
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 8; ++i) {
      const float u = u0 + (u1 - u0) * (i + 0.5f) / 8, v = v0 + (v1 - v0) * (j + 0.5f) / 8;
      inside += (u - 0.5f) * (u - 0.5f) + (v - 0.5f) * (v - 0.5f) < 0.25f;
    }
  return std::max(inside, 1) / 64.0f;
}

std::shared_ptr<const EnvironmentSampling> build_sampling(std::shared_ptr<const TextureImage> image, EnvProjection proj,
                                                          TextureFilter filter, int W, int H) {
  auto s = std::make_shared<EnvironmentSampling>();
  const TextureImage& img = *image;
  const int w = img.width, h = img.height;
  s->width = W;
  s->height = H;
  std::vector<RGB> row_sums;
  std::vector<float> f = filtered_luminance(img, filter, &row_sums);
  if (W != w || H != h) {
    // Cell (i, j) of the sampling grid takes the mean of the texels it overlaps (whole texels:
    // a cell between two texels sees both, so no radiance falls outside the support).
    std::vector<float> g(static_cast<size_t>(W) * H);
    parallel_for(static_cast<size_t>(H), 0, [&](size_t j0, size_t j1) {
      for (size_t j = j0; j != j1; ++j) {
        const int ty0 = static_cast<int>(std::floor(double(j) * h / H));
        const int ty1 = std::min(h, std::max(ty0 + 1, static_cast<int>(std::ceil(double(j + 1) * h / H))));
        for (int i = 0; i < W; ++i) {
          const int tx0 = static_cast<int>(std::floor(double(i) * w / W));
          const int tx1 = std::min(w, std::max(tx0 + 1, static_cast<int>(std::ceil(double(i + 1) * w / W))));
          double sum = 0;
          for (int ty = ty0; ty < ty1; ++ty)
            for (int tx = tx0; tx < tx1; ++tx) sum += f[static_cast<size_t>(ty) * w + tx];
          g[j * W + i] = static_cast<float>(sum / ((ty1 - ty0) * (tx1 - tx0)));
        }
      }
    });
    f = std::move(g);
  }
  // Equirectangular: a row's cells span sin(theta) of solid angle per unit uv area, theta =
  // pi (1 - v) at the row's centre (PBR 3rd ed. eq. 14.9's Jacobian); mirror ball: the part of
  // each cell inside the ball (its uv area maps to solid angle at a constant rate).
  parallel_for(static_cast<size_t>(H), 0, [&](size_t j0, size_t j1) {
    for (size_t j = j0; j != j1; ++j) {
      const float sin_theta = std::sin(kPi * (j + 0.5f) / H);
      for (int i = 0; i < W; ++i)
        f[j * W + i] *= proj == EnvProjection::Equirectangular
                            ? sin_theta
                            : mirror_ball_coverage(float(i) / W, float(i + 1) / W, float(j) / H, float(j + 1) / H);
    }
  });
  s->distribution = PiecewiseConstant2D(f.data(), W, H);
  // The map's integral over the sphere from its texels (the light's power): each row's sum
  // times its band's exact solid angle per texel.
  double sum[3] = {0, 0, 0};
  for (int y = 0; y < h; ++y) {
    if (proj == EnvProjection::Equirectangular) {
      const double band = std::abs(std::cos(M_PI * y / h) - std::cos(M_PI * (y + 1) / h));
      for (int k = 0; k < 3; ++k) sum[k] += row_sums[y][k] * 2.0 * M_PI * band / w;
    } else {
      for (int x = 0; x < w; ++x) {
        const RGB c = img.decoded(img.texel(x, y)).rgb;
        const double dw =
            16.0 * mirror_ball_coverage(float(x) / w, float(x + 1) / w, float(y) / h, float(y + 1) / h) / (double(w) * h);
        for (int k = 0; k < 3; ++k) sum[k] += std::max(0.0f, c[k]) * dw;
      }
    }
  }
  s->integral = RGB(float(sum[0]), float(sum[1]), float(sum[2]));
  s->image = std::move(image);
  return s;
}

// ---- The shared cache ----

using Key = std::tuple<const TextureImage*, int, int, int, int>;
std::mutex g_cache_mutex;
std::map<Key, std::weak_ptr<const EnvironmentSampling>> g_cache;

std::shared_ptr<const EnvironmentSampling> shared_sampling(const std::shared_ptr<const TextureImage>& image,
                                                           EnvProjection proj, TextureFilter filter, int W, int H) {
  const Key key{image.get(), static_cast<int>(proj), static_cast<int>(filter), W, H};
  std::lock_guard lock(g_cache_mutex);  // one build per key; concurrent scenes wait, then share
  if (auto it = g_cache.find(key); it != g_cache.end())
    if (auto s = it->second.lock()) return s;
  auto s = build_sampling(image, proj, filter, W, H);
  for (auto it = g_cache.begin(); it != g_cache.end();) it = it->second.expired() ? g_cache.erase(it) : std::next(it);
  g_cache[key] = s;
  return s;
}

}  // namespace

size_t environment_sampling_cache_size() {
  std::lock_guard lock(g_cache_mutex);
  size_t n = 0;
  for (const auto& [k, v] : g_cache) n += !v.expired();
  return n;
}

// ---- Projections (Cycles' kernel/camera/projection.h, direction_to_equirectangular with range
// (-2pi, pi, -pi, pi) and direction_to_mirrorball) ----

Vec2 EnvironmentMap::equirectangular_uv(const Vec3& m) {
  float u = 0.5f - std::atan2(m.y, m.x) * (0.5f * kInvPi);
  if (u >= 1.0f) u -= 1.0f;
  const float v = 1.0f - std::acos(std::clamp(m.z, -1.0f, 1.0f)) * kInvPi;
  return {std::max(u, 0.0f), v};
}

Vec3 EnvironmentMap::equirectangular_direction(Vec2 uv) {
  const float phi = kPi - 2.0f * kPi * uv.x, theta = kPi * (1.0f - uv.y);
  const float st = std::sin(theta);
  return {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
}

Vec2 EnvironmentMap::mirror_ball_uv(const Vec3& m) {
  // The ball's normal halfway between the view direction (+Y) and m, scaled to the disc.
  Vec3 d(m.x, m.y - 1.0f, m.z);
  const float div = 2.0f * std::sqrt(std::max(-0.5f * d.y, 0.0f));
  if (div > 0.0f) d = d / div;
  return {0.5f * (d.x + 1.0f), 0.5f * (d.z + 1.0f)};
}

Vec3 EnvironmentMap::mirror_ball_direction(Vec2 uv) {
  const float x = 2.0f * uv.x - 1.0f, z = 2.0f * uv.y - 1.0f;
  if (x * x + z * z > 1.0f) return Vec3(0, 0, 0);
  const Vec3 n(x, -std::sqrt(std::max(1.0f - x * x - z * z, 0.0f)), z);
  const Vec3 I(0, -1, 0);  // reflection of the view ray about the ball's normal
  return n * (2.0f * dot(n, I)) - I;
}

// ---- The light ----

EnvironmentMap::EnvironmentMap(std::shared_ptr<const TextureImage> image, const EnvironmentMapOptions& options)
    : image_(std::move(image)), options_(options) {
  if (!image_ || image_->width <= 0 || image_->height <= 0) throw std::invalid_argument("environment map: no image");
  const auto& a = options_.to_map;
  for (const auto& row : a)
    for (float v : row)
      if (!std::isfinite(v)) throw std::invalid_argument("environment map: the transform is not finite");
  const double det = double(a[0][0]) * (double(a[1][1]) * a[2][2] - double(a[1][2]) * a[2][1]) -
                     double(a[0][1]) * (double(a[1][0]) * a[2][2] - double(a[1][2]) * a[2][0]) +
                     double(a[0][2]) * (double(a[1][0]) * a[2][1] - double(a[1][1]) * a[2][0]);
  if (!(std::abs(det) > 1e-12)) throw std::invalid_argument("environment map: the transform is singular (zero scale?)");
  det_ = static_cast<float>(std::abs(det));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {  // inverse = adjugate / det
      const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
      from_map_[r][c] = static_cast<float>((double(a[r1][c1]) * a[r2][c2] - double(a[r1][c2]) * a[r2][c1]) / det);
    }
  int W = options_.sampling_width, H = options_.sampling_height;
  if (W <= 0 || H <= 0) {  // Auto: the image's size, as Cycles
    W = image_->width;
    H = image_->height;
  }
  options_.sampling_width = W;
  options_.sampling_height = H;
  sampling_ = shared_sampling(image_, options_.projection, options_.filter, W, H);
}

EnvironmentMap::~EnvironmentMap() = default;

Vec3 EnvironmentMap::map_vector(const Vec3& d) const {
  const auto& a = options_.to_map;
  return {a[0][0] * d.x + a[0][1] * d.y + a[0][2] * d.z, a[1][0] * d.x + a[1][1] * d.y + a[1][2] * d.z,
          a[2][0] * d.x + a[2][1] * d.y + a[2][2] * d.z};
}

bool EnvironmentMap::project(const Vec3& dir, Vec2* uv, float* jac, float* len) const {
  const Vec3 v = map_vector(dir);
  *len = length(v);
  if (!(*len > 0) || !std::isfinite(*len)) return false;
  const Vec3 m = v / *len;
  if (options_.projection == EnvProjection::Equirectangular) {
    *uv = equirectangular_uv(m);
    *jac = 2.0f * kPi * kPi * std::sqrt(std::max(0.0f, 1.0f - m.z * m.z));
  } else {
    *uv = mirror_ball_uv(m);
    *jac = 16.0f;
  }
  return true;
}

RGB EnvironmentMap::radiance_at(Vec2 uv) const {
  RGB c = image_->lookup(uv, TextureWrap::Repeat, options_.filter).rgb * options_.scale;
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(c[k])) c[k] = 0.0f;
  return c;
}

float EnvironmentMap::density_at(Vec2 uv, float jac, float len) const {
  if (!(jac > 0)) return 0.0f;
  const float p = sampling_->distribution.pdf(uv) / jac * det_ / (len * len * len);
  return std::isfinite(p) ? p : 0.0f;
}

RGB EnvironmentMap::eval(const Vec3& dir) const {
  Vec2 uv;
  float jac, len;
  return project(dir, &uv, &jac, &len) ? radiance_at(uv) : RGB(0.0f);
}

bool EnvironmentMap::sample_uv(Vec2 u, Vec3* dir, float* pdf, Vec2* uv_out) const {
  float pdf_uv = 0;
  const Vec2 uv = sampling_->distribution.sample(u, &pdf_uv);
  if (!(pdf_uv > 0)) return false;
  Vec3 m;
  float jac;  // solid angle per unit uv area in the map's frame
  if (options_.projection == EnvProjection::Equirectangular) {
    m = equirectangular_direction(uv);
    jac = 2.0f * kPi * kPi * std::sin(kPi * (1.0f - uv.y));
  } else {
    m = mirror_ball_direction(uv);
    if (length_squared(m) == 0) return false;
    jac = 16.0f;  // the ball's reflection maps uv area to solid angle at a constant 4 x 4
  }
  if (!(jac > 0)) return false;
  const auto& b = from_map_;
  const Vec3 w(b[0][0] * m.x + b[0][1] * m.y + b[0][2] * m.z, b[1][0] * m.x + b[1][1] * m.y + b[1][2] * m.z,
               b[2][0] * m.x + b[2][1] * m.y + b[2][2] * m.z);
  const float len = length(w);
  if (!(len > 0) || !std::isfinite(len)) return false;
  *dir = w / len;
  // Density of d = normalize(A^-1 m): p_m |det A| / |A d|^3, and |A d| = 1 / |A^-1 m|.
  *pdf = pdf_uv / jac * det_ * len * len * len;
  *uv_out = uv;
  return std::isfinite(*pdf) && *pdf > 0;
}

bool EnvironmentMap::sample(Vec2 u, Vec3* dir, float* pdf) const {
  Vec2 uv;
  return sample_uv(u, dir, pdf, &uv);
}

bool EnvironmentMap::sample_eval(Vec2 u, Vec3* dir, float* pdf, RGB* radiance) const {
  Vec2 uv;
  if (!sample_uv(u, dir, pdf, &uv)) return false;
  // The texel position drawn: projecting *dir back would give uv again up to float rounding.
  *radiance = radiance_at(uv);
  return true;
}

float EnvironmentMap::pdf(const Vec3& dir) const {
  Vec2 uv;
  float jac, len;
  return project(dir, &uv, &jac, &len) ? density_at(uv, jac, len) : 0.0f;
}

RGB EnvironmentMap::eval_pdf(const Vec3& dir, const RayState&, float* pdf) const {
  Vec2 uv;
  float jac, len;
  if (!project(dir, &uv, &jac, &len)) {
    *pdf = 0.0f;
    return RGB(0.0f);
  }
  *pdf = density_at(uv, jac, len);
  return radiance_at(uv);
}

RGB EnvironmentMap::integral() const { return sampling_->integral * options_.scale; }
int EnvironmentMap::sampling_width() const { return sampling_->width; }
int EnvironmentMap::sampling_height() const { return sampling_->height; }
size_t EnvironmentMap::sampling_bytes() const { return sampling_->distribution.bytes(); }

std::string EnvironmentMap::identity() const {
  const auto& a = options_.to_map;
  return fmt::format("map {} {} {} [{} {} {} {} {} {} {} {} {}] {} {} {} {}x{}", image_->path, int(options_.projection),
                     int(options_.filter), a[0][0], a[0][1], a[0][2], a[1][0], a[1][1], a[1][2], a[2][0], a[2][1], a[2][2],
                     options_.scale.r, options_.scale.g, options_.scale.b, sampling_->width, sampling_->height);
}

}  // namespace gp
