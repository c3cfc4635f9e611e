// Small fixed-size vector maths for the renderer. Plain structs on purpose: Embree and the
// integrators want float triples, and Eigen is kept for the dense/sparse systems it is good at.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace gp {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 1.0f / kPi;
inline constexpr float kInv2Pi = 1.0f / (2.0f * kPi);
inline constexpr float kInv4Pi = 1.0f / (4.0f * kPi);
inline constexpr float kInfinity = std::numeric_limits<float>::infinity();

struct Vec2 {
  float x = 0, y = 0;
  constexpr Vec2() = default;
  constexpr Vec2(float x_, float y_) : x(x_), y(y_) {}
  Vec2 operator+(Vec2 b) const { return {x + b.x, y + b.y}; }
  Vec2 operator-(Vec2 b) const { return {x - b.x, y - b.y}; }
  Vec2 operator*(float s) const { return {x * s, y * s}; }
};

struct Vec3 {
  float x = 0, y = 0, z = 0;
  constexpr Vec3() = default;
  constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  constexpr explicit Vec3(float s) : x(s), y(s), z(s) {}
  float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  Vec3 operator+(const Vec3& b) const { return {x + b.x, y + b.y, z + b.z}; }
  Vec3 operator-(const Vec3& b) const { return {x - b.x, y - b.y, z - b.z}; }
  Vec3 operator-() const { return {-x, -y, -z}; }
  Vec3 operator*(float s) const { return {x * s, y * s, z * s}; }
  Vec3 operator/(float s) const { float inv = 1.0f / s; return {x * inv, y * inv, z * inv}; }
  Vec3& operator+=(const Vec3& b) { x += b.x; y += b.y; z += b.z; return *this; }
  Vec3& operator-=(const Vec3& b) { x -= b.x; y -= b.y; z -= b.z; return *this; }
  Vec3& operator*=(float s) { x *= s; y *= s; z *= s; return *this; }
};
inline Vec3 operator*(float s, const Vec3& v) { return v * s; }

inline float dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline float absdot(const Vec3& a, const Vec3& b) { return std::abs(dot(a, b)); }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length_squared(const Vec3& v) { return dot(v, v); }
inline float length(const Vec3& v) { return std::sqrt(dot(v, v)); }
inline Vec3 normalize(const Vec3& v) { return v / length(v); }
inline Vec3 vmin(const Vec3& a, const Vec3& b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
inline Vec3 vmax(const Vec3& a, const Vec3& b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
inline float max_component(const Vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }
inline bool is_finite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
// Reflect wo about n (both pointing away from the surface).
inline Vec3 reflect(const Vec3& wo, const Vec3& n) { return -wo + n * (2.0f * dot(wo, n)); }

// Snell's law, the one place it is written (pbrt-v4's Refract): the direction refracted from w
// about n, w on n's side (cos_i = dot(n, w) >= 0), for the relative index eta = n_t / n_i (the
// index across the surface over the index on w's side). False on total internal reflection. A
// template so the manifold walk's double-precision Eigen vectors share it.
template <class V, class Real>
bool refract_oriented(const V& w, const V& n, Real cos_i, Real eta, V* wt) {
  const Real sin2_t = std::max(Real(0), Real(1) - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= Real(1)) return false;
  const Real cos_t = std::sqrt(Real(1) - sin2_t);
  *wt = -w / eta + n * (cos_i / eta - cos_t);
  return true;
}

// Refraction of w about n from either side, for eta = n_t / n_i seen from the side n points to:
// from below, n and eta are flipped. `etap` (if given) receives the relative index crossed.
inline bool refract(const Vec3& w, Vec3 n, float eta, float* etap, Vec3* wt) {
  float cos_i = dot(n, w);
  if (cos_i < 0) {  // w on the inside: flip the interface
    eta = 1.0f / eta;
    cos_i = -cos_i;
    n = -n;
  }
  if (!refract_oriented(w, n, cos_i, eta, wt)) return false;
  if (etap) *etap = eta;
  return true;
}

inline float clamp(float v, float lo, float hi) { return std::min(std::max(v, lo), hi); }
inline float safe_sqrt(float v) { return std::sqrt(std::max(0.0f, v)); }
inline float sqr(float v) { return v * v; }
inline float lerp(float t, float a, float b) { return a + t * (b - a); }

struct Bounds3 {
  Vec3 lo{kInfinity}, hi{-kInfinity};
  void extend(const Vec3& p) { lo = vmin(lo, p); hi = vmax(hi, p); }
  bool empty() const { return lo.x > hi.x; }
  Vec3 diagonal() const { return hi - lo; }
  Vec3 center() const { return (lo + hi) * 0.5f; }
};

// Cycles' per-object Ray Visibility switches as bits: camera, and the three kinds of bounce
// ray, whose kind is the BSDF lobe that sampled them (a transmission of any roughness is
// kRayTransmission; diffuse and glossy are reflections). BsdfSample::lobe and the lobe masks of
// Bsdf::eval/pdf use the same bits.
enum RayVisibility : uint8_t { kRayCamera = 1, kRayDiffuse = 2, kRayGlossy = 4, kRayTransmission = 8 };
inline constexpr uint8_t kAllLobes = kRayDiffuse | kRayGlossy | kRayTransmission;

// Motion blur: the shutter time (0: shutter open, 1: shutter close) of the camera path or
// photon pass the calling thread traces. Every ray made on the thread takes it (Ray::time), so
// the rays of one path (bounces, shadow rays, offset paths) share their path's time without
// each call site passing it on; parallel_for and parallel_for_tiles hand the caller's time to
// their workers (a pass's time reaches all its tasks). Set by ShutterTime scopes: per camera
// path (paths/camera_path.h), per pass (Scene::pass_shutter_time). A scene without motion never
// sets it: it stays 0 and every image is what it was before motion blur.
namespace detail {
inline thread_local float t_shutter_time = 0.0f;
}
inline float shutter_time() { return detail::t_shutter_time; }
// Sets the calling thread's shutter time for its lifetime, then restores the previous one.
class ShutterTime {
 public:
  explicit ShutterTime(float t) : saved_(detail::t_shutter_time) { detail::t_shutter_time = t; }
  ~ShutterTime() { detail::t_shutter_time = saved_; }
  ShutterTime(const ShutterTime&) = delete;
  ShutterTime& operator=(const ShutterTime&) = delete;

 private:
  float saved_;
};

// What Blender's Light Path node reads of the ray that reached a shading point: Cycles' path
// flags and bounce counters (kernel/integrator/path_state.h), carried by the ray, advanced at
// each bounce (next()) and copied to the hit (SurfaceHit::ray, with the length travelled).
enum PathFlags : uint16_t {
  kPathCamera = 1, kPathShadow = 2, kPathDiffuse = 4, kPathGlossy = 8, kPathSingular = 16,
  kPathReflection = 32, kPathTransmission = 64,
};
struct RayState {
  uint16_t flags = 0;  // PathFlags; 0: not a path's ray (light emission evaluated for a light sample)
  uint16_t depth = 0, diffuse = 0, glossy = 0, transmission = 0, transparent = 0;
  float length = 0.0f;  // Ray Length: the distance to the shading point (set at the hit)
  static RayState camera() {
    RayState s;
    s.flags = kPathCamera;
    return s;
  }
  // The state of the ray a BSDF sample starts (Cycles' path_state_next): a transparent pass
  // keeps the flags and counts a transparent bounce; any other bounce counts one, is a
  // reflection (diffuse or glossy bounce) or a transmission, and diffuse, glossy, or glossy and
  // singular (a smooth lobe).
  RayState next(bool transmission_, bool diffuse_, bool singular, bool transparent_) const {
    RayState s = *this;
    s.length = 0.0f;
    if (transparent_) {
      ++s.transparent;
      return s;
    }
    ++s.depth;
    s.flags = transmission_ ? kPathTransmission : kPathReflection;
    if (transmission_) ++s.transmission;
    else if (diffuse_) ++s.diffuse;
    else ++s.glossy;
    s.flags |= diffuse_ ? kPathDiffuse : singular ? (kPathGlossy | kPathSingular) : kPathGlossy;
    return s;
  }
  // After a scattering in a medium: one bounce, a volume-scatter ray (no surface kind).
  RayState volume_next() const {
    RayState s = *this;
    s.length = 0.0f;
    ++s.depth;
    s.flags = 0;
    return s;
  }
};

struct Ray {
  Vec3 o, d;
  float tmin = 0.0f, tmax = kInfinity;
  // Shutter time in [0, 1] at which the ray looks at the scene (Embree's RTCRay::time): the
  // thread's path or pass time (shutter_time()) unless set.
  float time = shutter_time();
  // Set by Camera::generate_ray only: surfaces whose material is not visible to the camera
  // (Blender's object Visibility > Camera, off for light objects) let camera rays through.
  // Every other ray (bounces, photons, shadow rays) is built fresh and is not a camera ray.
  bool camera = false;
  // A camera ray whose closest hit was a holdout surface (CameraRays: the hit is dropped): the
  // path ends with no colour and alpha 0, no background behind it (Cycles' holdout).
  bool held_out = false;
  // A bounce ray's kind (kRayDiffuse, kRayGlossy or kRayTransmission), set by integrators that
  // honour surfaces' per-kind switches (Method::lobe_visibility; the gradient methods' offset
  // rays take their base's): surfaces hidden from that kind let it through. 0: not a bounce ray
  // of a known kind (photons: photon_tracer.cpp crosses hidden surfaces itself), every surface is there.
  uint8_t bounce = 0;
  RayState state;  // Light Path's view of this ray (default: not a path's ray)
  Ray() = default;
  Ray(const Vec3& o_, const Vec3& d_, float tmin_ = 0.0f, float tmax_ = kInfinity)
      : o(o_), d(d_), tmin(tmin_), tmax(tmax_) {}
  Vec3 at(float t) const { return o + d * t; }
};

// Row-major affine 4x4 transform (last row 0 0 0 1 implied for points/vectors).
struct Transform {
  float m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
  Vec3 point(const Vec3& p) const {
    return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
  }
  Vec3 vector(const Vec3& v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  Transform operator*(const Transform& b) const {
    Transform r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        r.m[i][j] = 0;
        for (int k = 0; k < 4; ++k) r.m[i][j] += m[i][k] * b.m[k][j];
      }
    return r;
  }
  // Normals transform by the inverse transpose of the 3x3 part.
  Vec3 normal(const Vec3& n) const;
  static Transform translate(const Vec3& t);
  static Transform scale(const Vec3& s);
  // Rotation by `degrees` about `axis` (right-handed).
  static Transform rotate(float degrees, const Vec3& axis);
};

// The inverse of an affine transform (3x3 part by its adjugate; identity where singular).
Transform invert_affine(const Transform& t);

}  // namespace gp
