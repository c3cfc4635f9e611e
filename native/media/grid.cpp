#include "media/grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "core/spectrum.h"

namespace gp {

Affine Affine::operator*(const Affine& b) const {
  Affine r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) {
      r.m[i][j] = m[i][0] * b.m[0][j] + m[i][1] * b.m[1][j] + m[i][2] * b.m[2][j] + (j == 3 ? m[i][3] : 0.0f);
    }
  return r;
}

bool Affine::inverse(Affine* out) const {
  const double a = m[0][0], b = m[0][1], c = m[0][2], d = m[1][0], e = m[1][1], f = m[1][2], g = m[2][0],
               h = m[2][1], k = m[2][2];
  const double det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g);
  if (!std::isfinite(det) || std::abs(det) < 1e-30) return false;
  const double inv[3][3] = {{(e * k - f * h) / det, (c * h - b * k) / det, (b * f - c * e) / det},
                            {(f * g - d * k) / det, (a * k - c * g) / det, (c * d - a * f) / det},
                            {(d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det}};
  for (int i = 0; i < 3; ++i) {
    double t = 0;
    for (int j = 0; j < 3; ++j) {
      out->m[i][j] = static_cast<float>(inv[i][j]);
      t -= inv[i][j] * m[j][3];
    }
    out->m[i][3] = static_cast<float>(t);
  }
  return out->is_finite();
}

bool Affine::is_finite() const {
  for (const auto& row : m)
    for (float v : row)
      if (!std::isfinite(v)) return false;
  return true;
}

void VoxelGrid::lookup(const Vec3& idx, float* out) const {
  const float fx = std::floor(idx.x), fy = std::floor(idx.y), fz = std::floor(idx.z);
  // Far outside (or NaN): the background, without integer overflow.
  constexpr float kFar = 1 << 30;
  if (!(std::abs(fx) < kFar && std::abs(fy) < kFar && std::abs(fz) < kFar)) {
    for (int c = 0; c < channels; ++c) out[c] = background[c];
    return;
  }
  const int i = static_cast<int>(fx), j = static_cast<int>(fy), k = static_cast<int>(fz);
  const float u = idx.x - fx, v = idx.y - fy, w = idx.z - fz;
  for (int c = 0; c < channels; ++c) {
    const float c00 = lerp(u, at(i, j, k, c), at(i + 1, j, k, c));
    const float c10 = lerp(u, at(i, j + 1, k, c), at(i + 1, j + 1, k, c));
    const float c01 = lerp(u, at(i, j, k + 1, c), at(i + 1, j, k + 1, c));
    const float c11 = lerp(u, at(i, j + 1, k + 1, c), at(i + 1, j + 1, k + 1, c));
    out[c] = lerp(w, lerp(v, c00, c10), lerp(v, c01, c11));
  }
}

GridMedium::GridMedium(std::shared_ptr<const VoxelGrid> density, std::shared_ptr<const VoxelGrid> color,
                       std::shared_ptr<const VoxelGrid> temperature, const Affine& object_to_world,
                       const GridMediumParams& params)
    : density_(std::move(density)), color_(std::move(color)), temperature_(std::move(temperature)), params_(params) {
  const VoxelGrid* first = density_ ? density_.get() : color_ ? color_.get() : temperature_.get();
  if (!first) throw std::invalid_argument("a grid medium needs at least one grid");
  // The index box of lookups: the union of the grids' boxes (they share one transform).
  std::array<int, 3> hi{};
  for (int a = 0; a < 3; ++a) {
    lo_[a] = first->lo[a];
    hi[a] = first->lo[a] + first->size[a];
  }
  for (const VoxelGrid* g : {density_.get(), color_.get(), temperature_.get()}) {
    if (!g) continue;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j)
        if (std::abs(g->index_to_object.m[i][j] - first->index_to_object.m[i][j]) >
            1e-5f * (1 + std::abs(first->index_to_object.m[i][j])))
          throw std::invalid_argument(
              fmt::format("grids '{}' and '{}' have different transforms (not resampled)", first->name, g->name));
    for (int a = 0; a < 3; ++a) {
      lo_[a] = std::min(lo_[a], g->lo[a]);
      hi[a] = std::max(hi[a], g->lo[a] + g->size[a]);
    }
  }
  for (int a = 0; a < 3; ++a) size_[a] = std::max(0, hi[a] - lo_[a]);
  const Affine index_to_world = object_to_world * first->index_to_object;
  Affine inverse;
  if (!index_to_world.inverse(&inverse))
    throw std::invalid_argument(fmt::format("grid '{}': its transform (with the object's) is singular", first->name));
  // Cycles' convention, not OpenVDB's: voxel i fills the cell [i, i + 1] of index space with its
  // value at i + 1/2 (kernel/device/cpu/image.h, NanoVDB trilinear lookups at x - 0.5). Lookups
  // here put values at integers: the index space of lookups is OpenVDB's shifted by -1/2.
  Affine shift;
  for (int a = 0; a < 3; ++a) shift.m[a][3] = -0.5f;
  world_to_index_ = shift * inverse;
  {
    const auto& m = index_to_world.m;
    const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                       m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    voxel_size_ = static_cast<float>(std::cbrt(std::abs(det)));
  }
  // World bounds: the corners of the voxels' cells (OpenVDB's index space).
  for (int c = 0; c < 8; ++c) {
    const Vec3 p(float(c & 1 ? hi[0] : lo_[0]), float(c & 2 ? hi[1] : lo_[1]), float(c & 4 ? hi[2] : lo_[2]));
    world_bounds_.extend(index_to_world.point(p));
  }
  build_blocks();
}

float GridMedium::density_at(const Vec3& idx) const {
  if (!density_) return 1.0f;
  float d;
  density_->lookup(idx, &d);
  return std::max(d, 0.0f);  // Cycles: fmaxf(density * primitive_density, 0)
}

RGB GridMedium::color_at(const Vec3& idx) const {
  if (!color_) return params_.color;
  float c[4];
  color_->lookup(idx, c);
  if (color_->channels == 1) c[1] = c[2] = c[0];
  // A smoke domain's colour (channels 4: r d, g d, b d, d): Cycles unpremultiplies after the
  // interpolation (kernel/geom/volume.h, volume_attribute_value_to_float3).
  if (color_->channels == 4 && c[3] > 1e-6f && c[3] != 1.0f)
    for (int k = 0; k < 3; ++k) c[k] /= c[3];
  return params_.color * RGB(std::max(c[0], 0.0f), std::max(c[1], 0.0f), std::max(c[2], 0.0f));
}

RGB GridMedium::blackbody_at(const Vec3& idx) const {
  if (!(params_.blackbody_intensity > 0)) return RGB(0.0f);
  float T = params_.temperature;
  if (temperature_) {
    float t;
    temperature_->lookup(idx, &t);
    T *= std::max(t, 0.0f);
  }
  T = std::max(T, 0.0f);
  // Stefan-Boltzmann (svm_node_principled_volume): sigma 1e-6 / pi x mix(1, T^4, intensity).
  const float T4 = sqr(sqr(T));
  const float sigma = 5.670373e-8f * 1e-6f / kPi;
  const float intensity = sigma * lerp(params_.blackbody_intensity, 1.0f, T4);
  if (!(intensity > 1e-5f)) return RGB(0.0f);  // Cycles' CLOSURE_WEIGHT_CUTOFF
  return params_.blackbody_tint * blackbody_rgb(T) * intensity;
}

void GridMedium::build_blocks() {
  for (int a = 0; a < 3; ++a) nblocks_[a] = std::max(1, (size_[a] + 1 + kBlock - 1) / kBlock);
  blocks_.assign(size_t(nblocks_[0]) * nblocks_[1] * nblocks_[2], Bound{});
  // Background bound (outside every box).
  auto bound_of = [&](int i, int j, int k, Bound& b) {
    if (density_) b.density = std::max(b.density, std::max(density_->at(i, j, k), 0.0f));
    else b.density = 1.0f;
    if (color_) {
      // (Premultiplied: an unpremultiplied interpolation is a weighted mean of the voxels' own
      // colours where the alpha is positive, else the premultiplied value; both are bounded.)
      const float alpha = color_->channels == 4 ? color_->at(i, j, k, 3) : 0.0f;
      for (int c = 0; c < 3; ++c) {
        float v = std::max(color_->at(i, j, k, color_->channels == 1 ? 0 : c), 0.0f);
        if (alpha > 0) v = std::max(v, v / alpha);
        b.color[c] = std::max(b.color[c], params_.color[c] * v);
      }
    } else {
      b.color = params_.color;
    }
    if (temperature_) b.temperature = std::max(b.temperature, params_.temperature * std::max(temperature_->at(i, j, k), 0.0f));
    else b.temperature = std::max(0.0f, params_.temperature);
  };
  const int far = std::numeric_limits<int>::min() / 2;
  bound_of(far, far, far, outside_);
  // A block covers [lo - 1 + b kBlock, lo - 1 + (b + 1) kBlock) in index space (grid.h, walk);
  // the trilinear stencil of a point there reads voxels from lo - 1 + b kBlock to lo + (b + 1) kBlock - 1.
  for (int bz = 0; bz < nblocks_[2]; ++bz)
    for (int by = 0; by < nblocks_[1]; ++by)
      for (int bx = 0; bx < nblocks_[0]; ++bx) {
        Bound& b = blocks_[(size_t(bz) * nblocks_[1] + by) * nblocks_[0] + bx];
        const int i0 = lo_[0] - 1 + bx * kBlock, j0 = lo_[1] - 1 + by * kBlock, k0 = lo_[2] - 1 + bz * kBlock;
        for (int k = k0; k <= k0 + kBlock; ++k)
          for (int j = j0; j <= j0 + kBlock; ++j)
            for (int i = i0; i <= i0 + kBlock; ++i) bound_of(i, j, k, b);
      }
  global_ = outside_;
  for (const Bound& b : blocks_) {
    global_.density = std::max(global_.density, b.density);
    for (int c = 0; c < 3; ++c) global_.color[c] = std::max(global_.color[c], b.color[c]);
    global_.temperature = std::max(global_.temperature, b.temperature);
  }
}

RGB blackbody_rgb(float T) {
  // A table from 800 K (below: that colour, as blackbody_rec709 clamps) to 12000 K in steps of
  // 10 K, linear between; above, the curve changes slowly: computed directly.
  constexpr float kLo = 800.0f, kHi = 12000.0f, kStep = 10.0f;
  constexpr int kN = static_cast<int>((kHi - kLo) / kStep) + 1;
  static const std::vector<RGB> table = [] {
    std::vector<RGB> t(kN);
    for (int i = 0; i < kN; ++i) t[i] = blackbody_rec709(kLo + i * kStep);
    return t;
  }();
  if (!(T > kLo)) return table[0];
  if (T >= kHi) return blackbody_rec709(T);
  const float x = (T - kLo) / kStep;
  const int i = std::min(static_cast<int>(x), kN - 2);
  const float f = x - i;
  return table[i] * (1 - f) + table[i + 1] * f;
}

}  // namespace gp
