// Heterogeneous media over voxel grids (issue 32, second landing): the grids of an OpenVDB file
// (media/vdb_file.h reads them; OpenVDB's types stay there), Principled Volume's coefficients
// over them as Cycles 3.4 computes them per shading point (kernel/svm/closure.h,
// svm_node_principled_volume), and a majorant grid for delta and ratio tracking.
//
// A grid is dense here: OpenVDB's sparse tree is copied into an array over its active voxels'
// bounding box (Blender's smoke caches and Volume objects are small: a limit of kMaxGridVoxels
// keeps memory bounded, an error beyond). Values are looked up trilinearly between voxel centres
// and are the grid's background outside its bounding box. VoxelGrid::lookup puts a voxel's value
// at its integer index coordinates (OpenVDB's BoxSampler); a GridMedium follows Cycles instead
// (voxel i fills the cell [i, i + 1], its value at i + 1/2: grid.cpp).
//
// The majorant grid (pbrt-v4's MajorantGrid, Novak et al. 2018 "Monte Carlo methods for volumetric
// light transport simulation" §4.1): the maximum of every grid over each block of kBlock^3 voxels,
// widened by one voxel (the trilinear stencil reaches that far), so that a bound of the
// coefficients holds everywhere in the block. A ray walks the blocks it crosses (a 3D DDA,
// Amanatides & Woo 1987) and takes each block's bound as its majorant there.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/math.h"

namespace gp {

inline constexpr int64_t kMaxGridVoxels = int64_t(512) * 512 * 512;

// An affine map, row-major 3x4 (points: rows times (x, y, z, 1)).
struct Affine {
  float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  Vec3 point(const Vec3& p) const {
    return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
  }
  Vec3 vector(const Vec3& v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  Affine operator*(const Affine& b) const;
  // The inverse; false when singular (a degenerate transform: an error for the caller to name).
  bool inverse(Affine* out) const;
  bool is_finite() const;
};

// One grid: scalar (channels 1), vector (channels 3, a colour) or a colour premultiplied by an
// alpha (channels 4: a smoke domain's colour times its density, as Blender hands it to Cycles;
// media read its colour unpremultiplied after interpolation), dense over index box
// [lo, lo + size) and `background` outside.
struct VoxelGrid {
  std::string name;
  int channels = 1;
  std::array<int, 3> lo{0, 0, 0}, size{0, 0, 0};
  std::vector<float> data;  // (x fastest) * channels
  std::array<float, 4> background{0, 0, 0, 0};
  Affine index_to_object;   // the grid's own transform (OpenVDB: index space to the file's space)

  int64_t voxels() const { return int64_t(size[0]) * size[1] * size[2]; }
  // The value (channel c) at integer index (i, j, k): the background outside the box.
  float at(int i, int j, int k, int c = 0) const {
    i -= lo[0], j -= lo[1], k -= lo[2];
    if (i < 0 || j < 0 || k < 0 || i >= size[0] || j >= size[1] || k >= size[2]) return background[c];
    return data[((int64_t(k) * size[1] + j) * size[0] + i) * channels + c];
  }
  // Trilinear lookup at continuous index coordinates (voxel centres at integers).
  void lookup(const Vec3& idx, float* out) const;
};

// Principled Volume over grids. Per point p (Cycles' svm_node_principled_volume):
//   d = max(density_grid(p), 0) (1 without a density grid), C = color x max(color_grid(p), 0)
//   sigma_s = d x C x density;  sigma_a = d x max(1 - C, 0) x max(1 - sqrt(absorption_color), 0) x density
//   emission = emission (constant) + blackbody_tint x intensity(T) x blackbody_rgb(T),
//     T = temperature x max(temperature_grid(p), 0), intensity(T) = sigma_SB 1e-6 / pi x mix(1, T^4, blackbody)
// Without a colour grid the coefficients are linear in d: the Medium's own sigma_a / sigma_s are
// those at d = 1 (what the exporter writes), so the per-channel (spectral) values are the
// homogeneous medium's scaled by d, exactly.
struct GridMediumParams {
  float density = 1.0f;
  RGB color{1.0f}, absorption_color{0.0f};
  float blackbody_intensity = 0.0f;
  RGB blackbody_tint{1.0f};
  float temperature = 1000.0f;
};

class GridMedium {
 public:
  static constexpr int kBlock = 8;  // voxels per majorant block along each axis

  // Grids may be null (not in the file / not asked for); at least one must be given. All
  // grids given must share one transform and index box (Blender's caches and Volume objects
  // do; the loader resamples nothing: an error names the grid otherwise). object_to_world: the
  // object's matrix.
  GridMedium(std::shared_ptr<const VoxelGrid> density, std::shared_ptr<const VoxelGrid> color,
             std::shared_ptr<const VoxelGrid> temperature, const Affine& object_to_world,
             const GridMediumParams& params);

  const GridMediumParams& params() const { return params_; }
  bool has_color_grid() const { return color_ != nullptr; }
  bool emits_blackbody() const { return params_.blackbody_intensity > 0; }
  // World space bounds of the grids' boxes (the Volume object's bounding box).
  Bounds3 world_bounds() const { return world_bounds_; }
  // Index space of the grids (the world_to_index of lookups).
  const Affine& world_to_index() const { return world_to_index_; }
  // A voxel's edge in world units (the cube root of its volume).
  float voxel_size() const { return voxel_size_; }

  // ---- Per point (p in index space) ----
  float density_at(const Vec3& idx) const;  // d (>= 0)
  RGB color_at(const Vec3& idx) const;      // C = color x colour grid (>= 0)
  // Blackbody emission (RGB, W sr^-1 m^-3) at p; 0 when the medium has none.
  RGB blackbody_at(const Vec3& idx) const;

  // ---- Bounds per majorant block ----
  struct Bound {
    float density = 0;  // max d
    RGB color{0.0f};    // max C per channel
    float temperature = 0;  // max T (K)
  };
  const Bound& global_bound() const { return global_; }
  // Walks the blocks that the ray o + t d (index space) crosses over [t0, t1), calling
  // f(t_enter, t_exit, bound) in order; f returns false to stop. Outside the blocks: the
  // background's bound.
  template <class F>
  void walk(const Vec3& o, const Vec3& d, float t0, float t1, F&& f) const;

 private:
  const Bound& block(int bx, int by, int bz) const {
    return blocks_[(size_t(bz) * nblocks_[1] + by) * nblocks_[0] + bx];
  }
  void build_blocks();

  std::shared_ptr<const VoxelGrid> density_, color_, temperature_;
  GridMediumParams params_;
  Affine world_to_index_;
  Bounds3 world_bounds_;
  float voxel_size_ = 1.0f;
  std::array<int, 3> lo_{0, 0, 0}, size_{0, 0, 0};  // the common index box
  std::array<int, 3> nblocks_{0, 0, 0};
  std::vector<Bound> blocks_;
  Bound outside_;  // the backgrounds' bound
  Bound global_;   // the bound of every block and the background
};

// The Rec.709 colour of a black body at T kelvin normalised to luminance 1 (Cycles'
// svm_math_blackbody_color_rec709 fits the same curve), from a table built once.
RGB blackbody_rgb(float T);

template <class F>
void GridMedium::walk(const Vec3& o, const Vec3& d, float t0, float t1, F&& f) const {
  // The blocks' box in index space: (lo - 1, lo + size), where a trilinear lookup reads some
  // voxel of the box (beyond, only the background); block b covers [lo - 1 + b kBlock,
  // lo - 1 + (b + 1) kBlock) along each axis.
  const float origin[3] = {lo_[0] - 1.0f, lo_[1] - 1.0f, lo_[2] - 1.0f};
  const float oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  // Clip [t0, t1) to the box.
  float ta = t0, tb = t1;
  for (int a = 0; a < 3; ++a) {
    const float lo = origin[a], hi = origin[a] + size_[a] + 1;
    if (dd[a] == 0) {
      if (oo[a] < lo || oo[a] >= hi) ta = kInfinity;
      continue;
    }
    float u = (lo - oo[a]) / dd[a], v = (hi - oo[a]) / dd[a];
    if (u > v) std::swap(u, v);
    ta = std::max(ta, u);
    tb = std::min(tb, v);
  }
  if (!(ta < tb)) {
    f(t0, t1, outside_);
    return;
  }
  if (ta > t0 && !f(t0, ta, outside_)) return;
  // DDA over blocks from ta.
  int cell[3], step[3];
  float next[3], delta[3];
  for (int a = 0; a < 3; ++a) {
    const float x = oo[a] + dd[a] * ta - origin[a];
    cell[a] = std::clamp(static_cast<int>(std::floor(x / kBlock)), 0, nblocks_[a] - 1);
    if (dd[a] > 0) {
      step[a] = 1;
      next[a] = ta + ((cell[a] + 1) * kBlock - x) / dd[a];
      delta[a] = kBlock / dd[a];
    } else if (dd[a] < 0) {
      step[a] = -1;
      next[a] = ta + (cell[a] * kBlock - x) / dd[a];
      delta[a] = -kBlock / dd[a];
    } else {
      step[a] = 0;
      next[a] = kInfinity;
      delta[a] = kInfinity;
    }
  }
  float t = ta;
  for (int guard = 0; guard < 1 << 20 && t < tb; ++guard) {
    const int a = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : (next[1] < next[2] ? 1 : 2);
    const float t_exit = std::min(next[a], tb);
    if (t_exit > t && !f(t, t_exit, block(cell[0], cell[1], cell[2]))) return;
    t = t_exit;
    cell[a] += step[a];
    if (cell[a] < 0 || cell[a] >= nblocks_[a]) break;
    next[a] += delta[a];
  }
  // (Round-off may leave the walk a hair short of the box's exit: that gap takes every block's bound.)
  if (t < tb && !f(t, tb, global_)) return;
  if (tb < t1) f(tb, t1, outside_);
}

}  // namespace gp
