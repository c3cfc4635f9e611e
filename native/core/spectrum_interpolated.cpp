// RGB -> spectrum for colours met per hit: Jakob & Hanika's coefficients interpolated in their
// table (§4), which is fitted at build time and compiled in (core/spectrum_table.h). Apart from
// core/spectrum.cpp so that the table's generator links the fit without the table.
#include <algorithm>
#include <cmath>

#include "core/spectrum.h"
#include "core/spectrum_table.h"

namespace gp {

RgbSpectrum RgbSpectrum::reflectance_interpolated(const RGB& in) {
  namespace tb = spectrum_table;
  RgbSpectrum s;
  const float rgb[3] = {clamp(in.r, 0, 1), clamp(in.g, 0, 1), clamp(in.b, 0, 1)};
  if (rgb[0] == rgb[1] && rgb[1] == rgb[2]) {  // greys are exact, as reflectance()
    s.value_ = rgb[0];
    return s;
  }
  const int l = rgb[0] >= rgb[1] ? (rgb[0] >= rgb[2] ? 0 : 2) : (rgb[1] >= rgb[2] ? 1 : 2);
  const float z = rgb[l];  // > 0: not a grey
  const float* zs = tb::kZ;
  constexpr int n = tb::kRes - 1;
  const float fx = rgb[(l + 1) % 3] / z * n, fy = rgb[(l + 2) % 3] / z * n;
  const int i = std::min(static_cast<int>(fx), n - 1), j = std::min(static_cast<int>(fy), n - 1);
  // Below z[1]: the spectrum at z[1], scaled by z / z[1].
  const int k = std::clamp(static_cast<int>(std::upper_bound(zs, zs + tb::kRes, z) - zs) - 1, 1, n - 1);
  const float tx = fx - i, ty = fy - j, tz = std::max(0.0f, (z - zs[k]) / (zs[k + 1] - zs[k]));
  if (z < zs[1]) s.scale_ = z / zs[1];
  float c[3] = {0, 0, 0};
  for (int dk = 0; dk < 2; ++dk)
    for (int dj = 0; dj < 2; ++dj)
      for (int di = 0; di < 2; ++di) {
        const float w = (dk ? tz : 1 - tz) * (dj ? ty : 1 - ty) * (di ? tx : 1 - tx);
        const float* e = &tb::kCoefficients[tb::index(l, k + dk, j + dj, i + di)];
        for (int d = 0; d < 3; ++d) c[d] += w * e[d];
      }
  s.constant_ = false;
  s.c0_ = c[0];
  s.c1_ = c[1];
  s.c2_ = c[2];
  return s;
}

RgbSpectrum RgbSpectrum::illuminant_interpolated(const RGB& rgb) {
  const float m = std::max(0.0f, rgb.max_component());
  if (!(m > 0) || !std::isfinite(m)) return reflectance(RGB(0.0f));
  return reflectance_interpolated(rgb / m).scaled(m);
}

}  // namespace gp
