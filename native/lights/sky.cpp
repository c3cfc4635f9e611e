#include "lights/sky.h"

#include <Eigen/Dense>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>

#include "core/frame.h"
#include "core/parallel.h"
#include "core/spectrum.h"
#include "lights/environment_map.h"

namespace gp {

namespace {

// ---- Nishita's atmosphere (intern/sky/source/sky_nishita.cpp: its constants and method) ----

constexpr double kRayleighScale = 8e3;       // Rayleigh scale height (m)
constexpr double kMieScale = 1.2e3;          // Mie scale height (m)
constexpr double kMieCoeff = 2e-5;           // Mie scattering coefficient (m^-1)
constexpr double kMieExtinction = 1.11;      // Mie extinction / scattering
constexpr double kMieG = 0.76;               // aerosols' anisotropy
constexpr double kEarthRadius = 6360e3;      // m
constexpr double kAtmosphereRadius = 6420e3;  // m
constexpr int kSteps = 32;                   // segments of the view ray
constexpr int kWavelengths = 21;             // 380, 400, ..., 780 nm
constexpr double kLambda0 = 380, kLambdaStep = 20;

double wavelength(int i) { return kLambda0 + kLambdaStep * i; }

// The sun's spectral irradiance above the atmosphere (W m^-2 nm^-1): a 5778 K black body
// seen under the sun's solid angle (6.79016e-5 sr, pi (R_sun / 1 AU)^2 with R_sun = 695 450 km,
// the value the model's table was made with).
double sun_irradiance(double lambda_nm) {
  constexpr double h = 6.62607015e-34, c = 299792458.0, k = 1.380649e-23, T = 5778.0;
  const double l = lambda_nm * 1e-9;
  const double planck = 2.0 * h * c * c / (l * l * l * l * l) / std::expm1(h * c / (l * k * T));  // W m^-2 sr^-1 m^-1
  return planck * 6.79016e-5 * 1e-9;
}

// Rayleigh scattering of sea-level air (m^-1): lambda^-4, 5.4248e-5 at 380 nm.
double rayleigh_coeff(double lambda_nm) {
  const double r = 380.0 / lambda_nm;
  return 5.424820087636473e-5 * r * r * r * r;
}

// Ozone absorption at the model's reference density (m^-1) at 380, 400, ..., 780 nm: measured
// cross sections times a number density, the sky model's data (no formula gives them).
constexpr double kOzone[kWavelengths] = {
    3.25126849861e-9, 5.85395365047e-9, 1.977191155085e-8, 7.309568762914e-8, 2.0084561514287e-7,
    4.0383958096161e-7, 6.3551335912363e-7, 9.670704118097e-7, 1.5479740042441e-6, 2.09038647223331e-6,
    2.46128056164565e-6, 2.73551299461512e-6, 2.15125863128643e-6, 1.59051840791988e-6, 1.12356197979857e-6,
    7.3527551487574e-7, 4.6450130357806e-7, 3.3096079921048e-7, 2.251261229267800e-7, 1.487912926649e-7,
    1.6828623364192e-7};

double density_rayleigh(double h) { return std::exp(-h / kRayleighScale); }
double density_mie(double h) { return std::exp(-h / kMieScale); }
double density_ozone(double h) {  // a tent between 10 and 40 km, 1 at 25 km
  if (h >= 10000.0 && h < 25000.0) return h / 15000.0 - 2.0 / 3.0;
  if (h >= 25000.0 && h < 40000.0) return -(h / 15000.0 - 8.0 / 3.0);
  return 0.0;
}
double phase_rayleigh(double mu) { return 3.0 / (16.0 * M_PI) * (1.0 + mu * mu); }
double phase_mie(double mu) {  // Cornette-Shanks
  const double g2 = kMieG * kMieG;
  return 3.0 * (1.0 - g2) * (1.0 + mu * mu) / (8.0 * M_PI * (2.0 + g2) * std::pow(1.0 + g2 - 2.0 * kMieG * mu, 1.5));
}

using V3 = Eigen::Vector3d;

// Distance from p along unit d to where the ray leaves the atmosphere.
double atmosphere_exit(const V3& p, const V3& d) {
  const double b = 2.0 * d.dot(p), c = p.squaredNorm() - kAtmosphereRadius * kAtmosphereRadius;
  return 0.5 * (-b + std::sqrt(std::max(0.0, b * b - 4.0 * c)));
}

// The model's test for the Earth's shadow: a sun below the horizon whose line meets the ground.
bool earth_shadows(const V3& p, const V3& sun) {
  if (sun.z() >= 0) return false;
  const double b = 2.0 * sun.dot(p), c = p.squaredNorm() - kEarthRadius * kEarthRadius;
  return b * b - 4.0 * c >= 0.0;
}

// Gauss-Laguerre quadrature of 8 nodes (Golub-Welsch: the eigenvalues of the Laguerre
// polynomials' Jacobi matrix, weights the squared first components), with the sky model's
// substitution: nodes scaled by 1/25 of the ray (the last node stays inside the atmosphere),
// weights times e^x / 25, so that sum_i w_i g(x_i) integrates the density along the ray.
struct Quadrature {
  std::array<double, 8> node, weight;
  Quadrature() {
    Eigen::Matrix<double, 8, 8> J = Eigen::Matrix<double, 8, 8>::Zero();
    for (int i = 0; i < 8; ++i) {
      J(i, i) = 2.0 * i + 1.0;
      if (i < 7) J(i, i + 1) = J(i + 1, i) = i + 1.0;
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 8, 8>> es(J);
    for (int i = 0; i < 8; ++i) {
      const double x = es.eigenvalues()(i), v = es.eigenvectors()(0, i);
      node[i] = x / 25.0;
      weight[i] = v * v * std::exp(x) / 25.0;
    }
  }
};

// Optical depth (Rayleigh, Mie, ozone densities integrated, m) from p along unit d to space.
V3 optical_depth(const V3& p, const V3& d) {
  static const Quadrature q;
  const double len = atmosphere_exit(p, d);
  V3 od(0, 0, 0);
  for (int i = 0; i < 8; ++i) {
    const double h = (p + d * (q.node[i] * len)).norm() - kEarthRadius;
    od += V3(density_rayleigh(h), density_mie(h), density_ozone(h)) * q.weight[i];
  }
  return od * len;
}

// The CIE 1931 2-degree colour matching functions at 380, 400, ..., 780 nm (the CIE's table,
// which the sky model integrates with). Not core/spectrum.h's analytic fit: at these 21 points
// its x-bar is off by up to 0.01, which made the zenith 2.4 % too red and 0.6 % too dim in green.
constexpr double kCmf[kWavelengths][3] = {
    {0.001368, 0.000039, 0.006450}, {0.014310, 0.000396, 0.067850}, {0.134380, 0.004000, 0.645600},
    {0.348280, 0.023000, 1.747060}, {0.290800, 0.060000, 1.669200}, {0.095640, 0.139020, 0.812950},
    {0.004900, 0.323000, 0.272000}, {0.063270, 0.710000, 0.078250}, {0.290400, 0.954000, 0.020300},
    {0.594500, 0.995000, 0.003900}, {0.916300, 0.870000, 0.001650}, {1.062200, 0.631000, 0.000800},
    {0.854450, 0.381000, 0.000190}, {0.447900, 0.175000, 0.000020}, {0.164900, 0.061000, 0.000000},
    {0.046770, 0.017000, 0.000000}, {0.011359, 0.004102, 0.000000}, {0.002899, 0.001047, 0.000000},
    {0.000690, 0.000249, 0.000000}, {0.000166, 0.000060, 0.000000}, {0.000042, 0.000015, 0.000000}};

struct Spectral {
  double rayleigh[kWavelengths], irradiance[kWavelengths];
  Vec3 cmf[kWavelengths];
  Spectral() {
    for (int i = 0; i < kWavelengths; ++i) {
      rayleigh[i] = rayleigh_coeff(wavelength(i));
      irradiance[i] = sun_irradiance(wavelength(i));
      cmf[i] = Vec3(float(kCmf[i][0]), float(kCmf[i][1]), float(kCmf[i][2]));
    }
  }
};
const Spectral& spectral() {
  static const Spectral s;
  return s;
}

// CIE XYZ of a spectrum sampled at the model's wavelengths (rectangle rule, 20 nm).
V3 to_xyz(const double* s) {
  V3 xyz(0, 0, 0);
  for (int i = 0; i < kWavelengths; ++i) {
    const Vec3& c = spectral().cmf[i];
    xyz += V3(c.x, c.y, c.z) * s[i];
  }
  return xyz * kLambdaStep;
}

// Single scattering of sunlight into the view ray (the model's 32 midpoint segments): the
// light reaching each segment (optical depth to the sun by quadrature, none in the Earth's
// shadow), scattered by air (Rayleigh phase) and dust (Mie phase), attenuated back to the eye.
V3 single_scattering(const V3& dir, const V3& sun, const V3& eye, const V3& density_scale) {
  const Spectral& sp = spectral();
  const double len = atmosphere_exit(eye, dir), seg = len / kSteps;
  const double mu = dir.dot(sun);
  const double pr = phase_rayleigh(mu), pm = phase_mie(mu);
  double spectrum[kWavelengths] = {};
  V3 od(0, 0, 0);
  V3 p = eye + dir * (0.5 * seg);
  for (int s = 0; s < kSteps; ++s, p += dir * seg) {
    const double h = p.norm() - kEarthRadius;
    const V3 density = density_scale.cwiseProduct(V3(density_rayleigh(h), density_mie(h), density_ozone(h)));
    od += density * seg;
    if (earth_shadows(p, sun)) continue;
    const V3 total = od + density_scale.cwiseProduct(optical_depth(p, sun));
    for (int i = 0; i < kWavelengths; ++i) {
      const double tau = total.x() * sp.rayleigh[i] + total.y() * kMieExtinction * kMieCoeff + total.z() * kOzone[i];
      const double scatter = density.x() * sp.rayleigh[i] * pr + density.y() * kMieCoeff * pm;
      spectrum[i] += std::exp(-tau) * scatter * sp.irradiance[i] * seg;
    }
  }
  return to_xyz(spectrum);
}

// The sun's radiance seen along `dir` through air and dust (no ozone, as the model), its
// irradiance spread over the disc's solid angle.
V3 sun_radiance(const V3& dir, double altitude, double air, double dust, double solid_angle) {
  const Spectral& sp = spectral();
  const V3 od = optical_depth(V3(0, 0, kEarthRadius + altitude), dir);
  double spectrum[kWavelengths];
  for (int i = 0; i < kWavelengths; ++i)
    spectrum[i] = sp.irradiance[i] * std::exp(-(sp.rayleigh[i] * od.x() * air + kMieExtinction * kMieCoeff * od.y() * dust)) / solid_angle;
  return to_xyz(spectrum);
}

V3 geographic(double lat, double lon) { return V3(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat)); }

// XYZ -> Blender 3.4's scene linear (Rec.709): the inverse of its OCIO XYZ role's matrix
// (datafiles/colormanagement/luts/srgb_to_xyz.spimtx).
RGB xyz_to_scene_linear(const V3& xyz) {
  static const Eigen::Matrix3d m = [] {
    Eigen::Matrix3d to_xyz;
    to_xyz << 0.4124564, 0.3575761, 0.1804375, 0.2126729, 0.7151522, 0.0721750, 0.0193339, 0.1191920, 0.9503041;
    return Eigen::Matrix3d(to_xyz.inverse());
  }();
  const V3 rgb = m * xyz;
  return RGB(float(rgb.x()), float(rgb.y()), float(rgb.z()));
}

RGB clipped(RGB c) {
  for (int k = 0; k < 3; ++k) c[k] = std::isfinite(c[k]) ? std::max(c[k], 0.0f) : 0.0f;
  return c;
}

// Cycles' angle between unit vectors, accurate for small angles (util/math: precise_angle).
double precise_angle(const Vec3& a, const Vec3& b) {
  return 2.0 * std::atan2(double(length(a - b)), double(length(a + b)));
}

// Cycles 3.4's spherical coordinates of the sky models: theta from +Z, phi = atan2(x, y).
void sky_spherical(const Vec3& d, float* theta, float* phi) {
  *theta = std::acos(std::clamp(d.z, -1.0f, 1.0f));
  *phi = std::atan2(d.x, d.y);
}

// ---- Preetham (SIGGRAPH 1999, appendix A.2) ----

float perez(const float* l, float theta, float gamma) {
  const float cg = std::cos(gamma);
  return (1.0f + l[0] * std::exp(l[1] / std::cos(theta))) * (1.0f + l[2] * std::exp(l[3] * gamma) + l[4] * cg * cg);
}

}  // namespace

SkyTexture::SkyTexture(const SkyOptions& o, int threads) : options_(normalized(o)) {
  for (float v : {o.sun_size, o.sun_intensity, o.sun_elevation, o.sun_rotation, o.altitude, o.air_density, o.dust_density,
                  o.ozone_density, o.turbidity, o.sun_direction.x, o.sun_direction.y, o.sun_direction.z, o.scale.r, o.scale.g,
                  o.scale.b})
    if (!std::isfinite(v)) throw std::invalid_argument("sky: a setting is not finite");
  if (o.model == SkyModel::Nishita) {
    const double alt = options_.altitude, e = options_.sun_elevation;
    const V3 eye(0, 0, kEarthRadius + alt), sun = geographic(e, 0.0);
    const V3 scale(o.air_density, o.dust_density, o.ozone_density);
    // The image: rows from the horizon (y = 0) to the zenith, latitude (pi/2 + half a row)
    // (y / H)^2 so that rows crowd the horizon; columns from longitude -pi, the half away from
    // the sun mirrored onto the other (the sky is symmetric about the sun's azimuth).
    const int W = kNishitaWidth, H = kNishitaHeight;
    texels_.assign(size_t(W) * H, RGB(0.0f));
    const double lat_step = 0.5 * M_PI / H, lon_step = 2.0 * M_PI / W;
    // Rows on every thread: each texel is computed alone, so the image is the same bit for bit.
    parallel_for(static_cast<size_t>(H), threads, [&](size_t y0, size_t y1) {
      for (size_t y = y0; y != y1; ++y) {
        const double t = double(y) / H, lat = (0.5 * M_PI + 0.5 * lat_step) * t * t;
        for (int x = 0; x < W / 2; ++x) {
          const RGB c = xyz_to_scene_linear(single_scattering(geographic(lat, lon_step * x - M_PI), sun, eye, scale));
          texels_[y * W + x] = texels_[y * W + (W - 1 - x)] = c;
        }
      }
    });
    const double half = 0.5 * options_.sun_size;
    const double solid_angle = 2.0 * M_PI * (1.0 - std::cos(half));
    sun_bottom_ = xyz_to_scene_linear(sun_radiance(geographic(std::max(e - half, 0.0), 0.0), alt, o.air_density, o.dust_density, solid_angle));
    sun_top_ = xyz_to_scene_linear(sun_radiance(geographic(std::max(e + half, 0.0), 0.0), alt, o.air_density, o.dust_density, solid_angle));
    // The sun's direction as Blender 3.4 renders it (measured with Cycles' equirectangular
    // camera): elevation e, azimuth `rotation` from +Y towards +X.
    sun_dir_ = nishita_sun_direction(options_.sun_elevation, options_.sun_rotation);
    sun_cos_half_ = std::cos(half);
    sun_one_minus_cos_ = 2.0 * std::sin(0.5 * half) * std::sin(0.5 * half);
  } else {
    const float len = length(o.sun_direction);
    const Vec3 sd = len > 0 ? o.sun_direction / len : Vec3(0, 0, 1);
    sky_spherical(sd, &sun_theta_, &sun_phi_);
    const float T = o.turbidity, T2 = T * T, th = sun_theta_, th2 = th * th, th3 = th2 * th;
    const float chi = (4.0f / 9.0f - T / 120.0f) * (kPi - 2.0f * th);
    zenith_[0] = ((4.0453f * T - 4.9710f) * std::tan(chi) - 0.2155f * T + 2.4192f) * 0.06f;  // Y (Cycles' 0.06)
    zenith_[1] = (0.00166f * th3 - 0.00375f * th2 + 0.00209f * th) * T2 +
                 (-0.02903f * th3 + 0.06377f * th2 - 0.03202f * th + 0.00394f) * T +
                 (0.11693f * th3 - 0.21196f * th2 + 0.06052f * th + 0.25886f);  // x
    zenith_[2] = (0.00275f * th3 - 0.00610f * th2 + 0.00317f * th) * T2 +
                 (-0.04214f * th3 + 0.08970f * th2 - 0.04153f * th + 0.00516f) * T +
                 (0.15346f * th3 - 0.26756f * th2 + 0.06670f * th + 0.26688f);  // y
    const float c[3][5] = {
        {0.1787f * T - 1.4630f, -0.3554f * T + 0.4275f, -0.0227f * T + 5.3251f, 0.1206f * T - 2.5771f, -0.0670f * T + 0.3703f},
        {-0.0193f * T - 0.2592f, -0.0665f * T + 0.0008f, -0.0004f * T + 0.2125f, -0.0641f * T - 0.8989f, -0.0033f * T + 0.0452f},
        {-0.0167f * T - 0.2608f, -0.0950f * T + 0.0092f, -0.0079f * T + 0.2102f, -0.0441f * T - 1.6537f, -0.0109f * T + 0.0529f}};
    for (int k = 0; k < 3; ++k) {
      for (int i = 0; i < 5; ++i) perez_[k][i] = c[k][i];
      zenith_[k] /= perez(perez_[k], 0.0f, th);  // value at the zenith: F(0, theta_s)
    }
  }
  build_sampling(threads);
}

RGB SkyTexture::lookup(float x, float y) const {
  const int W = kNishitaWidth, H = kNishitaHeight;
  const float px = x * W - 0.5f, py = y * H - 0.5f;
  const float fx = std::floor(px), fy = std::floor(py);
  const float tx = px - fx, ty = py - fy;
  auto at = [&](int i, int j) { return texels_[size_t(std::clamp(j, 0, H - 1)) * W + std::clamp(i, 0, W - 1)]; };
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  return (at(ix, iy) * (1 - tx) + at(ix + 1, iy) * tx) * (1 - ty) + (at(ix, iy + 1) * (1 - tx) + at(ix + 1, iy + 1) * tx) * ty;
}

bool SkyTexture::in_sun(const Vec3& dir) const {
  if (options_.model != SkyModel::Nishita || !options_.sun_disc || dir.z < 0) return false;
  return precise_angle(dir, sun_dir_) < 0.5 * options_.sun_size;
}

RGB SkyTexture::nishita(const Vec3& dir, bool with_sun) const {
  float theta, phi;
  sky_spherical(dir, &theta, &phi);
  const float e = options_.sun_elevation, size = options_.sun_size, half = 0.5f * size;
  if (with_sun && in_sun(dir)) {
    // The sun disc (kernel/svm/sky.h): its light between the disc's bottom and top, limb
    // darkened; only above the horizon.
    const float elev = 0.5f * kPi - theta;
    RGB c(0.0f);
    if (e + half > 0.0f) {
      const float y = e - half > 0.0f ? (elev - e) / size + 0.5f : elev / (e + half);
      c = (sun_bottom_ + (sun_top_ - sun_bottom_) * y) * options_.sun_intensity;
    }
    const float r = static_cast<float>(precise_angle(dir, sun_dir_)) / half;
    return c * (1.0f - 0.6f * (1.0f - std::sqrt(std::max(0.0f, 1.0f - r * r))));
  }
  // The image's column: azimuth from the sun's (phi = sun_rotation), the sun at x = 1/2
  // (the image is symmetric about it, so the sense of x does not matter).
  float x = (phi - options_.sun_rotation + kPi) / (2.0f * kPi);
  x -= std::floor(x);
  if (dir.z >= 0.0f) return lookup(x, std::sqrt(std::max(0.0f, (0.5f * kPi - theta) / (0.5f * kPi))));
  if (dir.z < -0.4f) return RGB(0.0f);
  const float fade = 1.0f + 2.5f * dir.z;  // the ground fades to black
  return lookup(x, -0.5f) * (fade * fade * fade);
}

RGB SkyTexture::preetham(const Vec3& dir) const {
  float theta, phi;
  sky_spherical(dir, &theta, &phi);
  const float cos_g = std::sin(theta) * std::sin(sun_theta_) * std::cos(sun_phi_ - phi) + std::cos(theta) * std::cos(sun_theta_);
  const float gamma = std::acos(std::clamp(cos_g, -1.0f, 1.0f));
  theta = std::min(theta, 0.5f * kPi - 0.001f);  // the horizon's value below it
  const float Y = zenith_[0] * perez(perez_[0], theta, gamma);
  const float x = zenith_[1] * perez(perez_[1], theta, gamma);
  const float y = zenith_[2] * perez(perez_[2], theta, gamma);
  if (y == 0.0f) return RGB(0.0f);
  return xyz_to_scene_linear(V3(x / y * Y, Y, Y != 0.0f ? (1.0f - x - y) / y * Y : 0.0f));
}

RGB SkyTexture::radiance(const Vec3& dir, bool with_sun) const {
  return clipped(options_.model == SkyModel::Nishita ? nishita(dir, with_sun) : preetham(dir));
}

RGB SkyTexture::eval(const Vec3& dir) const { return clipped(radiance(dir, true) * options_.scale); }

// ---- Sampling ----

void SkyTexture::build_sampling(int threads) {
  // 512 x 256 equirectangular cells (Cycles' projection, environment_map.h), each the mean of
  // 2 x 2 evaluations of the sky without its sun.
  const int W = 512, H = 256, S = 2;
  sky_ = bake_directions(W, H, S, threads, [this](const Vec3& d) { return radiance(d, false); });
  // The sun disc's power: its mean radiance over a stratified grid of the cone.
  sun_integral_ = RGB(0.0f);
  if (options_.model == SkyModel::Nishita && options_.sun_disc && sun_one_minus_cos_ > 0) {
    const int n = 24;
    RGB sum(0.0f);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) sum += radiance(sample_sun(Vec2((a + 0.5f) / n, (b + 0.5f) / n)), true);
    sun_integral_ = sum * static_cast<float>(2.0 * M_PI * sun_one_minus_cos_ / (n * n));
    const float ps = sun_integral_.average(), pk = sky_.integral.average();
    p_sun_ = ps > 0 ? ps / (ps + std::max(pk, 0.0f)) : 0.0f;
  }
}

Vec3 SkyTexture::sample_sun(Vec2 u) const {
  // A uniform direction in the sun's cone: 1 - cos(theta) uniform in [0, 1 - cos(half)].
  const double one_minus_cos = u.x * sun_one_minus_cos_;
  const double sin_t = std::sqrt(std::max(0.0, one_minus_cos * (2.0 - one_minus_cos)));
  const double ph = 2.0 * M_PI * u.y;
  const Frame f(sun_dir_);
  return normalize(f.to_world(Vec3(float(sin_t * std::cos(ph)), float(sin_t * std::sin(ph)), float(1.0 - one_minus_cos))));
}

bool SkyTexture::sample(Vec2 u, Vec3* dir, float* pdf) const {
  if (p_sun_ > 0 && u.x < p_sun_) {
    *dir = sample_sun(Vec2(std::min(u.x / p_sun_, 0x1.fffffep-1f), u.y));
  } else {
    if (p_sun_ > 0) u.x = std::min((u.x - p_sun_) / (1.0f - p_sun_), 0x1.fffffep-1f);
    if (!sky_.sample(u, dir)) return false;
  }
  *pdf = this->pdf(*dir);
  return std::isfinite(*pdf) && *pdf > 0;
}

float SkyTexture::pdf(const Vec3& dir) const {
  float p = sky_.density(dir);
  if (p_sun_ > 0) {
    p *= 1.0f - p_sun_;
    if (precise_angle(dir, sun_dir_) <= 0.5 * options_.sun_size)
      p += static_cast<float>(p_sun_ / (2.0 * M_PI * sun_one_minus_cos_));
  }
  return std::isfinite(p) ? p : 0.0f;
}

std::string SkyTexture::identity() const { return describe(options_); }

Vec3 SkyTexture::nishita_sun_direction(float elevation, float rotation) {
  const double e = elevation, rot = rotation;
  return Vec3(float(std::cos(e) * std::sin(rot)), float(std::cos(e) * std::cos(rot)), float(std::sin(e)));
}

namespace {
thread_local bool t_sun_discs_off = false;
}
SkySunDiscsOff::SkySunDiscsOff() : previous_(t_sun_discs_off) { t_sun_discs_off = true; }
SkySunDiscsOff::~SkySunDiscsOff() { t_sun_discs_off = previous_; }
bool SkySunDiscsOff::active() { return t_sun_discs_off; }

SkyOptions SkyTexture::normalized(SkyOptions o) {
  if (o.model == SkyModel::Nishita) {
    // Cycles' clamps (scene/shader_nodes.cpp): altitude to [1 m, 59 999 m], the sun's size to
    // at least 1e-4 rad.
    o.altitude = std::clamp(o.altitude, 1.0f, 59999.0f);
    o.sun_size = std::max(o.sun_size, 1e-4f);
  }
  return o;
}

std::string SkyTexture::describe(const SkyOptions& o) {
  return fmt::format("sky {} {} {} {} {} {} {} {} {} {} ({} {} {}) {} ({} {} {})", int(o.model), o.sun_disc, o.sun_size,
                     o.sun_intensity, o.sun_elevation, o.sun_rotation, o.altitude, o.air_density, o.dust_density,
                     o.ozone_density, o.sun_direction.x, o.sun_direction.y, o.sun_direction.z, o.turbidity, o.scale.r,
                     o.scale.g, o.scale.b);
}

namespace {
std::mutex g_sky_mutex;
std::map<std::string, std::weak_ptr<const SkyTexture>> g_skies;
}  // namespace

std::shared_ptr<const SkyTexture> shared_sky(SkyOptions options) {
  options.scale = RGB(1.0f);
  const std::string key = SkyTexture::describe(SkyTexture::normalized(options));
  {
    std::lock_guard lock(g_sky_mutex);
    if (auto it = g_skies.find(key); it != g_skies.end())
      if (auto s = it->second.lock()) return s;
  }
  // Built outside the lock: the build runs parallel work, and a thread waiting in it may pick
  // up a task that asks for a sky (a lock held here would then deadlock it). Two threads asking
  // for the same new sky at once both build it; the first one stored is kept.
  auto s = std::make_shared<const SkyTexture>(options);
  std::lock_guard lock(g_sky_mutex);
  auto& slot = g_skies[key];
  if (auto other = slot.lock()) return other;
  slot = s;
  for (auto it = g_skies.begin(); it != g_skies.end();) it = it->second.expired() ? g_skies.erase(it) : std::next(it);
  return s;
}

size_t sky_cache_size() {
  std::lock_guard lock(g_sky_mutex);
  size_t n = 0;
  for (const auto& [k, v] : g_skies) n += !v.expired();
  return n;
}

}  // namespace gp
