// Jakob & Hanika's 2019 RGB -> spectrum coefficient table (their §4): its layout, its fit, and
// the stored copy. The fit runs once, at build time: native/tools/make_spectrum_table.cpp calls
// fit_coefficient_table() and writes the result as a C++ source (in the build folder) that is
// compiled into the core, so no process fits it (4.5 G instructions) and nothing is looked up on
// disk. core/spectrum.cpp's RgbSpectrum::reflectance_interpolated reads the stored copy.
//
// One table for every use: reflectances read it directly, illuminants (illuminant_interpolated)
// as a reflectance scaled by the colour's largest component. One gamut (the Rec.709 primaries of
// the spectral pipeline; core/spectrum.h).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace gp::spectrum_table {

// Three tables, one per largest RGB component l, over (x, y, z): z = that component on a grid
// dense near 0 and 1 (smoothstep, as theirs), x and y the next two components (cyclically)
// divided by z, uniform.
inline constexpr int kRes = 24;
// Entries: [l][k (z)][j (y)][i (x)][3 coefficients]; k = 0 (z = 0, black) is unused.
inline constexpr std::size_t kSize = 3 * 3 * std::size_t(kRes) * kRes * kRes;

inline constexpr std::size_t index(int l, int k, int j, int i) {
  return 3 * (((static_cast<std::size_t>(l) * kRes + k) * kRes + j) * kRes + i);
}

// ---- The fit (core/spectrum.cpp) ----

// The z grid: smoothstep(k / (kRes - 1)) as float.
std::array<float, kRes> fit_z_grid();
// The entries (l, k, j, i) for every k and i of one (l, j), into c (kSize floats; the others are
// left alone). Each (l, j) is fitted on its own (continuation within it only), so any subset can
// be refitted and compared with the stored table bit for bit.
void fit_coefficient_slice(int l, int j, float* c);
// The whole table (every slice, one after the other: the build runs it beside other jobs).
std::vector<float> fit_coefficient_table();

// ---- The stored copy (generated at build time; spectrum_table.cpp in the build folder) ----

extern const float kZ[kRes];
extern const float kCoefficients[kSize];

}  // namespace gp::spectrum_table
