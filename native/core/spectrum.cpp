#include "core/spectrum.h"

#include "core/spectrum_table.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace gp {

namespace {

// Piecewise Gaussian of Wyman et al. 2013, eq. 1: different widths left and right of the mean.
double lobe(double x, double mu, double sigma_left, double sigma_right) {
  const double t = (x - mu) / (x < mu ? sigma_left : sigma_right);
  return std::exp(-0.5 * t * t);
}

// The integration grid shared by every quadrature here: 5 nm trapezoid over the domain.
constexpr int kSteps = 94;
double grid_lambda(int i) { return kLambdaMin + double(kLambdaRange) * i / kSteps; }
double grid_weight(int i) { return (i == 0 || i == kSteps ? 0.5 : 1.0) * kLambdaRange / kSteps; }

// Tables built once: the XYZ -> RGB matrix and the RGB-weighted CMFs on the grid.
struct Tables {
  double y_integral = 0;
  Eigen::Matrix3d xyz_to_rgb;
  // rgb_bar[i] = xyz_to_rgb * cmf(lambda_i) * weight_i / y_integral: RGB of s is sum s_i rgb_bar_i.
  std::array<Eigen::Vector3d, kSteps + 1> rgb_bar;

  Tables() {
    Eigen::Vector3d white(0, 0, 0);
    std::array<Eigen::Vector3d, kSteps + 1> xyz;
    for (int i = 0; i <= kSteps; ++i) {
      const Vec3 c = cie_xyz_bar(static_cast<float>(grid_lambda(i)));
      xyz[i] = Eigen::Vector3d(c.x, c.y, c.z);
      white += xyz[i] * grid_weight(i);
    }
    y_integral = white.y();
    white /= y_integral;  // equal-energy white of the fit (about (1, 1, 1))
    // Rec.709 / sRGB primaries with the D65 white (IEC 61966-2-1), XYZ -> linear RGB.
    Eigen::Matrix3d m709;
    m709 << 3.2404542, -1.5371385, -0.4985314,
           -0.9692660, 1.8760108, 0.0415560,
            0.0556434, -0.2040259, 1.0572252;
    // Bradford chromatic adaptation from the equal-energy white to D65 (Lam 1985).
    Eigen::Matrix3d bradford;
    bradford << 0.8951, 0.2664, -0.1614,
               -0.7502, 1.7135, 0.0367,
                0.0389, -0.0685, 1.0296;
    const Eigen::Vector3d d65(0.95047, 1.0, 1.08883);
    const Eigen::Vector3d gain = (bradford * d65).cwiseQuotient(bradford * white);
    Eigen::Matrix3d m = m709 * bradford.inverse() * gain.asDiagonal() * bradford;
    // The published matrix maps D65 to (1, 1, 1) only to 4 digits: make white exact.
    const Eigen::Vector3d w_rgb = m * white;
    for (int r = 0; r < 3; ++r) m.row(r) /= w_rgb[r];
    xyz_to_rgb = m;
    for (int i = 0; i <= kSteps; ++i) rgb_bar[i] = m * xyz[i] * (grid_weight(i) / y_integral);
  }
};

const Tables& tables() {
  static const Tables t;
  return t;
}

// Jakob & Hanika 2019, eq. 3: algebraic sigmoid mapping R to (0, 1), and its derivative.
double sigmoid(double x) { return 0.5 + x / (2.0 * std::sqrt(1.0 + x * x)); }
double sigmoid_derivative(double x) { return 0.5 / std::pow(1.0 + x * x, 1.5); }

double grid_t(int i) { return double(i) / kSteps; }  // (lambda - min) / range on the grid

Eigen::Vector3d fit_rgb(const Eigen::Vector3d& c) {
  const Tables& tb = tables();
  Eigen::Vector3d rgb(0, 0, 0);
  for (int i = 0; i <= kSteps; ++i) {
    const double t = grid_t(i);
    rgb += tb.rgb_bar[i] * sigmoid(c[0] * t * t + c[1] * t + c[2]);
  }
  return rgb;
}

// Levenberg–Marquardt-damped Gauss–Newton steps of c toward the RGB `goal` (at most 40, until
// the squared RGB residual is below `tolerance`).
void refine_coefficients(Eigen::Vector3d& c, const Eigen::Vector3d& goal, double tolerance = 1e-14) {
  const Tables& tb = tables();
  double lm = 1e-6;
  for (int it = 0; it < 40; ++it) {
    Eigen::Vector3d rgb(0, 0, 0);
    Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
    for (int i = 0; i <= kSteps; ++i) {
      const double t = grid_t(i);
      const double x = c[0] * t * t + c[1] * t + c[2];
      rgb += tb.rgb_bar[i] * sigmoid(x);
      const double d = sigmoid_derivative(x);
      J.col(0) += tb.rgb_bar[i] * (d * t * t);
      J.col(1) += tb.rgb_bar[i] * (d * t);
      J.col(2) += tb.rgb_bar[i] * d;
    }
    const Eigen::Vector3d r = rgb - goal;
    const double err = r.squaredNorm();
    if (err < tolerance) break;
    // Damped normal equations; accept the step if it reduces the residual.
    bool improved = false;
    for (int tries = 0; tries < 12 && !improved; ++tries) {
      const Eigen::Matrix3d A = J.transpose() * J + lm * Eigen::Matrix3d::Identity();
      const Eigen::Vector3d step = A.ldlt().solve(-J.transpose() * r);
      const Eigen::Vector3d cn = c + step;
      if ((fit_rgb(cn) - goal).squaredNorm() < err) {
        c = cn;
        lm = std::max(lm * 0.1, 1e-12);
        improved = true;
      } else {
        lm *= 10;
      }
    }
    if (!improved) break;
  }
}

// The fit of the three coefficients to an RGB target, continued from `c` (whose own RGB is the
// first goal) toward the target in `steps` equal steps, as Jakob & Hanika build their table
// (§4); from c = 0 (grey 0.5) in 16 steps for a colour of its own.
Eigen::Vector3d fit_coefficients(const Eigen::Vector3d& target, Eigen::Vector3d c = Eigen::Vector3d::Zero(),
                                 int steps = 16, double tolerance = 1e-14) {
  const Eigen::Vector3d start = c.isZero() ? Eigen::Vector3d::Constant(0.5) : fit_rgb(c);
  for (int k = 1; k <= steps; ++k) {
    const double a = double(k) / steps;
    refine_coefficients(c, start * (1 - a) + target * a, tolerance);
  }
  return c;
}

// ---- Jakob & Hanika's coefficient table (their §4), for colours met per hit ----
//
// Each entry is fitted by continuation from its neighbour (a row of x cold from grey at z index
// kRes / 5, then along x, then up and down z), to 1e-6 in RGB. Below the first non-zero z the
// spectrum is the one there scaled down (z = 0 is black, which no sigmoid reaches): RGB is
// linear in the scale, so the colour stays exact. Run at build time (core/spectrum_table.h).
constexpr double kTableTolerance = 1e-12;

double smoothstep(double x) { return x * x * (3.0 - 2.0 * x); }

Eigen::Vector3d table_rgb_of(int l, double x, double y, double z) {
  Eigen::Vector3d rgb;
  rgb[l] = z;
  rgb[(l + 1) % 3] = x * z;
  rgb[(l + 2) % 3] = y * z;
  return rgb;
}

}  // namespace

namespace spectrum_table {

std::array<float, kRes> fit_z_grid() {
  std::array<float, kRes> z;
  for (int k = 0; k < kRes; ++k) z[k] = static_cast<float>(smoothstep(double(k) / (kRes - 1)));
  return z;
}

// One (l, j): its row along x at k0, then each x's column along z.
void fit_coefficient_slice(int l, int j, float* c) {
  const std::array<float, kRes> z = fit_z_grid();
  const int k0 = kRes / 5;
  auto store = [&](int k, int i, const Eigen::Vector3d& v) {
    for (int d = 0; d < 3; ++d) c[index(l, k, j, i) + d] = static_cast<float>(v[d]);
  };
  auto grid = [](int n) { return double(n) / (kRes - 1); };
  Eigen::Vector3d row(0, 0, 0);
  for (int i = 0; i < kRes; ++i) {
    row = fit_coefficients(table_rgb_of(l, grid(i), grid(j), z[k0]), row, i == 0 ? 16 : 2, kTableTolerance);
    store(k0, i, row);
    Eigen::Vector3d v = row;
    for (int k = k0 + 1; k < kRes; ++k) {
      v = fit_coefficients(table_rgb_of(l, grid(i), grid(j), z[k]), v, 1, kTableTolerance);
      store(k, i, v);
    }
    v = row;
    for (int k = k0 - 1; k >= 1; --k) {
      v = fit_coefficients(table_rgb_of(l, grid(i), grid(j), z[k]), v, 1, kTableTolerance);
      store(k, i, v);
    }
  }
}

std::vector<float> fit_coefficient_table() {
  std::vector<float> c(kSize, 0.0f);
  for (int l = 0; l < 3; ++l)
    for (int j = 0; j < kRes; ++j) fit_coefficient_slice(l, j, c.data());
  return c;
}

}  // namespace spectrum_table

float wrap_wavelength(float lambda) {
  float l = std::fmod(lambda - kLambdaMin, kLambdaRange);
  if (l < 0) l += kLambdaRange;
  const float w = kLambdaMin + l;
  return w >= kLambdaMax ? kLambdaMin : w;
}

SampledWavelengths SampledWavelengths::sample_uniform(float u, int count) {
  SampledWavelengths wl;
  wl.count = count;
  const float hero = kLambdaMin + u * kLambdaRange;
  const float spacing = kLambdaRange / count;
  for (int j = 0; j < count; ++j) wl.lambda[j] = wrap_wavelength(hero + j * spacing);
  return wl;
}

Vec3 cie_xyz_bar(float lambda) {
  // Wyman, Sloan & Shirley 2013, §2.2 "multi-lobe" fit (their eq. 2; lambda in nm).
  const double l = lambda;
  const double x = 1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) -
                   0.065 * lobe(l, 501.1, 20.4, 26.2);
  const double y = 0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1);
  const double z = 1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8);
  return Vec3(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
}

float cie_y_integral() { return static_cast<float>(tables().y_integral); }

RGB blackbody_rec709(float kelvin) {
  const double T = std::max(kelvin, 800.0f);
  Vec3 xyz(0.0f);
  for (float l = 380.0f; l <= 780.0f; l += 5.0f) {
    const double lm = l * 1e-9;
    const double b = 1.0 / (std::pow(lm, 5.0) * (std::exp(0.0143877735 / (lm * T)) - 1.0));  // Planck, up to a constant
    xyz = xyz + cie_xyz_bar(l) * static_cast<float>(b * 1e-20);
  }
  // XYZ to linear Rec.709 (D65), as Cycles' rec709 tables.
  const RGB c(3.2404542f * xyz.x - 1.5371385f * xyz.y - 0.4985314f * xyz.z,
              -0.9692660f * xyz.x + 1.8760108f * xyz.y + 0.0415560f * xyz.z,
              0.0556434f * xyz.x - 0.2040259f * xyz.y + 1.0572252f * xyz.z);
  const float y = 0.2126729f * c.r + 0.7151522f * c.g + 0.0721750f * c.b;  // Cycles' luminance weights
  const float inv = 1.0f / y;  // (as Vec3 / float: the Blackbody node bit for bit)
  return y > 0.0f ? RGB(c.r * inv, c.g * inv, c.b * inv) : RGB(1.0f);
}

RGB xyz_to_rgb(const Vec3& xyz) {
  const Eigen::Vector3d v = tables().xyz_to_rgb * Eigen::Vector3d(xyz.x, xyz.y, xyz.z);
  return RGB(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
}

RGB sample_to_rgb(const SpectralValues& L, const SampledWavelengths& wl) {
  Vec3 xyz(0, 0, 0);
  for (int j = 0; j < wl.count; ++j) xyz = xyz + cie_xyz_bar(wl.lambda[j]) * L[j];
  // Monte Carlo estimate of the XYZ integrals: mean over the set of L cmf / pdf, and Y(1) = 1.
  const float norm = 1.0f / (wl.count * SampledWavelengths::pdf() * cie_y_integral());
  return xyz_to_rgb(xyz * norm);
}

RgbSpectrum RgbSpectrum::reflectance(const RGB& in) {
  RgbSpectrum s;
  const RGB rgb(clamp(in.r, 0, 1), clamp(in.g, 0, 1), clamp(in.b, 0, 1));
  if (rgb.r == rgb.g && rgb.g == rgb.b) {  // greys (white and black included) are exact
    s.constant_ = true;
    s.value_ = rgb.r;
    return s;
  }
  const Eigen::Vector3d c = fit_coefficients(Eigen::Vector3d(rgb.r, rgb.g, rgb.b));
  s.constant_ = false;
  s.c0_ = static_cast<float>(c[0]);
  s.c1_ = static_cast<float>(c[1]);
  s.c2_ = static_cast<float>(c[2]);
  return s;
}

RgbSpectrum RgbSpectrum::illuminant(const RGB& rgb) {
  const float m = std::max(0.0f, rgb.max_component());
  if (m <= 0) return reflectance(RGB(0.0f));
  RgbSpectrum s = reflectance(rgb / m);
  s.scale_ = m;
  return s;
}

std::optional<std::vector<SpectralLine>> spectral_line_preset(const std::string& name) {
  if (name == "sodium") return std::vector<SpectralLine>{{588.995f, 2.0f}, {589.592f, 1.0f}};  // D2, D1
  if (name == "mercury")
    return std::vector<SpectralLine>{{404.66f, 0.8f}, {435.83f, 1.6f}, {546.07f, 2.0f}, {576.96f, 0.4f}, {579.07f, 0.4f}};
  return std::nullopt;
}

namespace {
float gaussian_sigma(float fwhm) { return fwhm / 2.35482f; }
}  // namespace

Vec3 spectral_lines_xyz(const std::vector<SpectralLine>& lines, float fwhm) {
  const double sigma = gaussian_sigma(fwhm);
  Vec3 xyz(0, 0, 0);
  constexpr int kSteps = 400;  // +-5 sigma
  for (const SpectralLine& l : lines) {
    const double h = 10.0 * sigma / kSteps;
    for (int i = 0; i < kSteps; ++i) {
      const double x = -5.0 * sigma + (i + 0.5) * h;
      const float lambda = static_cast<float>(l.nm + x);
      if (lambda < kLambdaMin || lambda >= kLambdaMax) continue;
      const double g = l.weight * std::exp(-x * x / (2 * sigma * sigma)) / (sigma * std::sqrt(2 * kPi));
      xyz = xyz + cie_xyz_bar(lambda) * static_cast<float>(g * h);
    }
  }
  return xyz * (1.0f / cie_y_integral());
}

RGB spectral_lines_rgb(const std::vector<SpectralLine>& lines, float fwhm) {
  const Vec3 xyz = spectral_lines_xyz(lines, fwhm);
  if (!(xyz.y > 0)) return RGB(0.0f);
  const RGB c = xyz_to_rgb(xyz * (1.0f / xyz.y));
  return RGB(std::max(0.0f, c.r), std::max(0.0f, c.g), std::max(0.0f, c.b));
}

RgbSpectrum RgbSpectrum::lines(const std::vector<SpectralLine>& lines, float fwhm, float scale) {
  if (lines.empty() || lines.size() > static_cast<size_t>(kMaxSpectralLines) || !(fwhm > 0))
    throw std::invalid_argument("line spectrum: 1.." + std::to_string(kMaxSpectralLines) + " lines and fwhm > 0");
  const float y = spectral_lines_xyz(lines, fwhm).y;
  if (!(y > 0)) throw std::invalid_argument("line spectrum has no luminance in 360-830 nm");
  RgbSpectrum s;
  s.constant_ = false;
  s.n_lines_ = static_cast<int>(lines.size());
  const float sigma = gaussian_sigma(fwhm);
  s.line_inv_2sigma2_ = 1.0f / (2 * sigma * sigma);
  for (int i = 0; i < s.n_lines_; ++i) {
    s.line_nm_[i] = lines[i].nm;
    s.line_peak_[i] = lines[i].weight / (sigma * std::sqrt(2 * kPi)) / y;  // luminance 1
  }
  s.scale_ = scale;
  return s;
}

float RgbSpectrum::operator()(float lambda) const {
  if (n_lines_ > 0) {
    float v = 0;
    for (int i = 0; i < n_lines_; ++i) {
      const float d = lambda - line_nm_[i];
      v += line_peak_[i] * std::exp(-d * d * line_inv_2sigma2_);
    }
    return v * scale_;
  }
  if (constant_) return value_ * scale_;
  const double t = (double(lambda) - kLambdaMin) / kLambdaRange;
  return static_cast<float>(sigmoid((c0_ * t + c1_) * t + c2_)) * scale_;
}

RGB RgbSpectrum::to_rgb() const {
  return spectrum_to_rgb([this](float l) { return (*this)(l); });
}

}  // namespace gp
