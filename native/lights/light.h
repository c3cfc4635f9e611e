// Lights: emissive triangles (area lights), point, spot, directional (sun), constant
// environment. Units are radiometric; the Blender addon converts Blender's conventions.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/motion.h"
#include "core/spectrum.h"
#include "core/math.h"
#include "core/sampling.h"
#include "lights/background.h"
#include "lights/environment_map.h"
#include "shading/graph.h"

namespace gp {

struct Light;
// An area light whose radiance its material's node graph gives (an Emission colour or strength
// linked into `nodes`): evaluated at each point where the light is hit or sampled. Light::emit
// holds its average over the triangle, which the light's selection and photons use.
struct EmissionGraph {
  std::shared_ptr<const shading::ShaderProgram> program;
  bool emission_linked = false, strength_linked = false;
  shading::InputSource emission, strength;
  RGB emission_constant{1.0f};
  float strength_constant = 1.0f;
  const shading::ShadingObject* object = nullptr;
  int prim = -1;       // the triangle in its mesh (mesh attributes)
  const shading::ShadingCamera* camera = nullptr;  // the scene's (Texture Coordinate Camera, Window)
  Vec2 uv0, uv1, uv2;  // the triangle's texture coordinates (barycentrics without a UV map)
  // Radiance at point p of light l seen along wo (unit, away from the surface).
  // `ray`: the path's ray that found p (Light Path); null for a light sample (no path flags).
  RGB at(const Light& l, const Vec3& p, const Vec3& wo, const RayState* ray = nullptr) const;
};

enum class LightType { Area, Point, Spot, Directional, Environment };

struct Light {
  LightType type = LightType::Point;
  std::string name;
  // Area, Environment: radiance (W sr^-1 m^-2). Point, Spot: intensity (W sr^-1).
  // Directional: irradiance on a surface facing the light (W m^-2).
  RGB emit{1.0f};
  Vec3 position;                 // point, spot
  Vec3 direction{0, 0, -1};      // spot axis / direction the sun's light travels (unit)
  // Spot cone (Blender's spot_size and spot_blend): cos of the half angle, and the width of
  // the smoothstep blend in cosine units ((1 - cos_half) * blend), as Cycles does.
  float spot_cos_half = 0.7071f;
  float spot_smooth = 0.0f;
  // Soft lights as Cycles 3.4 samples them for next-event estimation (still no geometry, so
  // camera and BSDF rays never hit them): a point or spot light of radius > 0 is a disk of
  // that radius facing the shading point, a sun of angle > 0 a cone of directions of
  // half-angle tangent sun_tan_half. Photons still leave the light's centre / axis.
  float radius = 0.0f;
  float sun_tan_half = 0.0f;
  // Area light triangle (world space), unit geometric normal, area.
  Vec3 p0, p1, p2, n;
  float area = 0.0f;
  bool two_sided = false;
  int mesh = -1, prim = -1;      // the emissive triangle this light is
  // An emissive triangle of a moving mesh (motion blur): the mesh over the shutter and the
  // triangle's vertex indices; p0, p1, p2, n and area are then the frame's, and sampling takes
  // the triangle at the thread's shutter time (core/math.h shutter_time).
  std::shared_ptr<const MeshMotion> motion;
  uint32_t tri[3] = {0, 0, 0};
  // A moving lamp (point, spot, sun; motion blur): its transforms over the shutter place
  // local_position and local_direction (the lamp's own space) where it is at the thread's
  // shutter time; position and direction are then the mid-shutter ones (selection, reports).
  std::shared_ptr<const TransformMotion> lamp_motion;
  Vec3 local_position, local_direction{0, 0, -1};
  std::shared_ptr<const EmissionGraph> emission_graph;  // area lights of graph-driven emission
  // Line emission spectrum (spectral modes); empty = the smooth spectrum of emit. emit is then
  // the lines' (clipped) RGB times the luminance.
  std::vector<SpectralLine> lines;
  float line_fwhm = 1.0f;
  // Cycles' Diffuse / Glossy / Transmission switches (kRay* bits, Material::visible_lobes):
  // which BSDF lobes this light lights, by next-event estimation and by BSDF rays alike.
  uint8_t visible_lobes = kAllLobes;
  // The environment's Camera switch (World > Settings > Ray Visibility > Camera): camera rays
  // that leave the scene see it, or black. Other lights are never seen by camera rays (area
  // lights: their surface's Material::visible_to_camera).
  bool visible_to_camera = true;
  // Environment: a World whose radiance varies with direction (background.h: an image,
  // environment_map.h; a sky, sky.h; or a sum of backgrounds), or null for the constant
  // `emit`. With a map, emit is its mean radiance (4 pi sr of it integrate to integral()).
  std::shared_ptr<const BackgroundTerm> map;
  // Light Path "Is Camera Ray" choosing another background for camera rays (Ray::camera):
  // what they see instead of emit / map, when camera_override.
  bool camera_override = false;
  RGB camera_emit{0.0f};
  std::shared_ptr<const BackgroundTerm> camera_map;

  // Cycles 3.4 does not sample a constant World as a light; where that changes what it lights
  // (a World hidden from some kinds, integrators/lobe_split.h), next-event estimation skips it
  // and BSDF rays alone find it, each with full weight.
  bool lit_by_bsdf_rays_only() const { return type == LightType::Environment && !map && visible_lobes != kAllLobes; }
  // Whether a ray of kind `kind` (kRayCamera or one lobe bit) sees this light.
  bool visible_to(uint8_t kind) const { return kind == kRayCamera ? visible_to_camera : (visible_lobes & kind) != 0; }
  bool is_delta() const { return type == LightType::Point || type == LightType::Spot || type == LightType::Directional; }
  bool is_infinite() const { return type == LightType::Directional || type == LightType::Environment; }
};

// Incident radiance from one light at a reference point, for next-event estimation.
struct LightSample {
  RGB L;                 // radiance arriving along -wi (for delta lights: intensity/d^2 or E)
  Vec3 wi;               // unit direction from the reference point towards the light
  float dist = kInfinity;  // distance to the light sample (infinity for distant lights)
  Vec3 p, n;             // the sampled point and its unit normal (area lights only)
  float pdf = 0;         // solid-angle pdf including the light-selection probability; delta: pmf
  bool delta = false;
  // A point/spot light of radius > 0 is sampled as a delta light (L already divided by the
  // point's density, pdf the selection pmf) but a path tracer may also hit its disk
  // (LightSet::intersect_disk): then this is the solid-angle pdf for MIS, else 0.
  float mis_pdf = 0;
  int light = -1;
};

// One photon leaving a light (photon tracing, thesis §5.3.4 "photon tracing passes"): its
// origin, unit direction of travel and the flux it carries, divided by every sampling
// probability (light selection included), so that the mean over emitted photons is the
// total emitted power.
struct PhotonEmission {
  Vec3 o, d;
  // Densities sample_le drew o and d with (light selection included in one of them), for the
  // path densities of multisampled PPM (msppm.h). Finite lights: pdf_pos per unit area
  // of the light (delta position: the selection pmf), pdf_dir per solid angle. Distant lights
  // (sun, environment): pdf_pos per unit area of the emission disk, pdf_dir per solid angle
  // (sun: the selection pmf, delta direction).
  float pdf_pos = 0, pdf_dir = 0;
  Vec3 n;                 // surface normal at the origin (area lights), else zero
  RGB power;              // W, already divided by all pdfs
  int light = -1;
};

// All lights of a scene with a power-proportional selection distribution.
class LightSet {
 public:
  LightSet() = default;
  // scene_bounds give distant lights their power (pi r^2 E) and the environment its extent.
  LightSet(std::vector<Light> lights, const Bounds3& scene_bounds);

  const std::vector<Light>& lights() const { return lights_; }
  bool empty() const { return lights_.empty(); }
  int environment() const { return environment_; }
  float selection_pmf(int light) const { return select_.empty() ? 0.0f : select_.pmf(light); }

  std::optional<LightSample> sample_li(const Vec3& p, float u_select, Vec2 u) const;
  // The light sample_li picks with u_select (in *light) and the point it aims at, neither
  // depending on the reference point: an area light's point drawn from u as sample_li draws it,
  // a point or spot light's centre; nullopt for distant lights. The centre of equiangular
  // sampling in media (paths/camera_path.h).
  std::optional<Vec3> sample_position(float u_select, Vec2 u, int* light) const;
  // Solid-angle pdf (selection included) that sample_li would pick the point `p_light` of
  // area light `light` as seen from `p` along unit wi (MIS weight when a BSDF ray hits it).
  float pdf_area(int light, const Vec3& p, const Vec3& p_light, const Vec3& wi) const;
  // Solid-angle pdf of sampling direction wi from the environment (0 if none).
  float pdf_environment(const Vec3& wi) const;
  // Radiance seen along a ray that leaves the scene; `camera_ray` (Ray::camera) selects the
  // background camera rays see where the World tells them apart (Light Path: Is Camera Ray).
  RGB environment_radiance(const Vec3& dir, bool camera_ray = false) const;
  // The same for a path's ray leaving the scene: a World graph (world_graph.h) sees its Light
  // Path state (Ray::state; a camera ray is one whatever its state says).
  RGB environment_radiance(const Ray& ray) const;
  // The same with pdf_environment(ray.d) in *pdf (a bounce ray's MIS weight), sharing the
  // map's projection of the direction.
  RGB environment_radiance(const Ray& ray, float* pdf) const;
  // True when the environment's radiance depends on direction (an image or sky): the spectral
  // methods then upsample each value they find instead of one spectrum for the light.
  bool environment_textured() const { return environment_ >= 0 && (lights_[environment_].map || lights_[environment_].camera_map); }
  // Whether camera rays that leave the scene see the environment (World > Ray Visibility >
  // Camera; true without one: there is nothing to hide).
  bool environment_visible_to_camera() const { return environment_ < 0 || lights_[environment_].visible_to_camera; }
  // The first point/spot light of radius > 0 whose disk (Cycles' sphere light: a disk facing
  // the ray's origin) the ray crosses before tmax: its index (else -1), the distance, the
  // radiance it sends back along the ray and the solid-angle pdf sample_li gives that point
  // (selection included, the LightSample::mis_pdf of that sample).
  int intersect_disk(const Ray& ray, float tmax, float* t, RGB* L, float* pdf) const;
  // Radiance leaving area light `light` towards direction w (away from the light).
  RGB area_radiance(int light, const Vec3& w) const;
  // The same at point p of the light (a graph-driven emission varies over the surface), seen by
  // a path's ray in state `ray` (SurfaceHit::ray; Light Path reads it) or by a light sample (null).
  RGB area_radiance(int light, const Vec3& w, const Vec3& p, const RayState* ray = nullptr) const;
  // Directional emission of a finite light along unit d, the factor sample_le's photon power is
  // proportional to: area lights radiance |cos| (per unit area), point and spot lights their
  // intensity (spot falloff included); 0 for distant lights. GPM's light-subpath shift
  // reconnects at the light vertex and needs it for the offset direction.
  RGB emitted(int light, const Vec3& d) const;
  // Where point or spot light `light` is at the thread's shutter time (a moving lamp moves).
  Vec3 position(int light) const;
  float power(int light) const;
  // Emission sampling for photon tracing: picks a light in proportion to power(), then a
  // point and a direction on it. Area: uniform point, cosine-weighted direction about the
  // emitting side (two-sided lights pick a side with probability 1/2). Point: uniform
  // sphere. Spot: uniform cone, weighted by the same Blender/Cycles falloff that sample_li
  // uses. Directional and environment: a disk of the scene's bounding radius perpendicular
  // to the direction, placed outside the bounds (constant environment: uniform direction).
  std::optional<PhotonEmission> sample_le(float u_select, Vec2 u_pos, Vec2 u_dir) const;
  // The densities sample_le would give light `light` emitting along unit d (PhotonEmission::
  // pdf_pos / pdf_dir; the point on an area light does not matter, it is uniform).
  void emission_pdf(int light, const Vec3& d, float& pdf_pos, float& pdf_dir) const;

 private:
  float spot_falloff(const Light& l, const Vec3& w_from_light) const;
  std::vector<Light> lights_;
  std::vector<int> disk_lights_;  // point and spot lights of radius > 0
  DiscreteDistribution select_;
  int environment_ = -1;
  float scene_radius_ = 1.0f;
  Vec3 scene_center_;
};

}  // namespace gp
