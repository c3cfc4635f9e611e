// BSDFs of the closed material set, evaluated in the local shading frame (normal = +z).
// Conventions (pbrt's): wo and wi both point away from the surface; eval() returns f without
// the cosine; pdf() is per solid angle of wi; sample() returns f, pdf and wi for one lobe
// chosen stochastically, with `delta` set for smooth (Dirac) lobes, whose f and pdf are the
// Dirac weights (their ratio is what matters). Transport mode selects the radiance or the
// importance (photon) form of refraction, which differ by eta^2 (Veach 1997, §5.2).
#pragma once

#include <memory>
#include <optional>

#include "core/color.h"
#include "core/math.h"
#include "materials/material.h"

namespace gp {

enum class TransportMode { Radiance, Importance };

// GGX alpha below which a conductor or dielectric is treated as smooth (a Dirac lobe), as
// pbrt-v4's TrowbridgeReitzDistribution::EffectivelySmooth: below it D overflows float and
// no sampler or density estimator could resolve the lobe anyway. is_delta() follows it.
inline constexpr float kSmoothAlpha = 1e-3f;

struct BsdfSample {
  RGB f;                 // BSDF value (Dirac weight for delta lobes)
  Vec3 wi;               // sampled direction, local frame
  float pdf = 0;         // solid-angle pdf (Dirac weight for delta lobes)
  bool delta = false;    // sampled a smooth (specular) lobe
  bool transmission = false;
  float eta = 1.0f;      // relative IOR crossed (1 for reflection)
  // The lobe it came from (kRayDiffuse, kRayGlossy or kRayTransmission): the kind of the bounce
  // ray it starts, for Cycles' per-kind ray visibility. Smooth reflections are glossy.
  uint8_t lobe = 0;
  // f and pdf are not the lobe's: pdf is a stand-in density (a function of the direction, for
  // MIS) and f = weight x pdf / |cos wi| with the sampler's weight, which one random walk
  // estimated (Multiscatter GGX, bsdf.cpp). Only f |cos| / pdf is the sample's weight.
  bool stochastic = false;
};

// Whether a sample passes straight through a Transparent BSDF (smooth, IOR 1: Cycles'
// LABEL_TRANSPARENT). Shadow rays pass those surfaces (paths/medium_walk.h), so a path keeps its
// MIS state across such a pass, as Cycles keeps mis_ray_pdf over transparent bounces
// (integrate_surface_bsdf_bssrdf_bounce), and photons that only passed them are direct light.
inline bool is_transparent_pass(const BsdfSample& bs) { return bs.delta && bs.transmission && bs.eta == 1.0f; }
struct MixComponents;  // below

// A material's BSDF parameters at one surface point: its constants, with the inputs an image
// texture drives looked up there. Plain values, cheap to make per hit.
struct BsdfParams {
  MaterialType type = MaterialType::Diffuse;
  RGB color{0.8f};
  float roughness = 0.0f;
  ConductorFresnel conductor_fresnel = ConductorFresnel::Schlick;
  Microfacet distribution = Microfacet::GGX;  // Material::distribution
  float ior = 1.5f;
  // Principled and clearcoat (Material's fields of the same names). The tints take the RGB base
  // colour's luminances, Cycles' two (0.3, 0.6, 0.1 for the specular tint; the scene's linear
  // Rec. 709 Y for the sheen), so a spectral `color` (one wavelength's grey) tints as its RGB.
  float specular_tint = 0.0f, sheen = 0.0f, sheen_tint = 0.5f, clearcoat = 0.0f;
  float specular_tint_lum = 0.0f, sheen_tint_lum = 0.0f;
  float anisotropy = 0.0f;  // Material::anisotropy (local x is the tangent)
  bool refraction_only = false;  // Material::refraction_only
  bool fresnel_at_normal = false;  // Material::fresnel_at_normal
  bool principled_glass = false;   // Material::principled_glass (reads specular_tint)
  bool separable_masking = false;  // Material::separable_masking
  const std::vector<float>* coat_albedo = nullptr;  // plastic (Material::coat_albedo)
  float mix_factor = 0.5f;
  bool mix_add = false;
  const Material *mix_a = nullptr, *mix_b = nullptr;
  // The surface's smooth normal (before a normal or bump map) in the shading frame, for the
  // bump shadowing term of diffuse lobes (bsdf.cpp); zero where no map bent the normal.
  Vec3 smooth_normal{0, 0, 0};
  // > 0: the parameters one wavelength (nm) sees, `color` a grey (materials/spectral_material.h);
  // a mix's components are then seen at the same wavelength. 0: RGB.
  float lambda = 0.0f;
  // Multiscatter GGX: the shading point's part of the key of its random walks' streams (set by
  // Bsdf from the point; bsdf.cpp).
  uint64_t walk_salt = 0;
  // A mix's components at the same point, evaluated once with the mix (bsdf_params), so that
  // eval, sample and pdf read them instead of re-running the components' graphs per call (as
  // Cycles' SVM writes every closure of a shader once per shading point). Null for other types
  // and for parameters made by hand (the components are then looked up per call).
  std::shared_ptr<const MixComponents> parts;
  // Cycles' Light Paths > Caustics at this point (filter_closures): the kinds of lobe kept (one
  // dropped scatters nothing: eval and pdf leave it out, a sample of it is no sample), and a
  // Principled's diffuse roughness where Filter Glossy raised `roughness` for its specular lobe
  // alone (-1: `roughness`).
  uint8_t lobes = kAllLobes;
  float diffuse_roughness = -1.0f;
  bool sharp = false;  // Material::sharp
};

// Cycles 3.4's Light Paths > Caustics at one shading point of a camera path, which the path so
// far decides (paths/camera_path.h):
//   Filter Glossy (integrator/surface_shader.h surface_shader_prepare_closures): with the smallest BSDF or
//   phase pdf of the path's non-singular bounces so far p_min and Filter Glossy g > 0, where
//   p_min / g < 1 every microfacet closure's alpha is raised to at least
//   blur_alpha = 0.5 sqrt(1 - p_min / g) (bsdf.h bsdf_blur: GGX, Beckmann, Ashikhmin-Shirley,
//   Multiscatter GGX, clearcoat; each axis of an anisotropic one). Cycles' singular closures
//   (Reflection, Refraction, Sharp Glass: Material::sharp, a Sharp node whose Roughness is
//   linked; an unlinked Sharp is GGX at 0 under Filter Glossy, shader_nodes.cpp) and the
//   Transparent BSDF are not blurred; nor is the scene format's plastic (not a Cycles closure:
//   its coat albedo table is the material's).
//   Caustics (svm_closure.h, __CAUSTICS_TRICKS__): where the ray that met the surface left a
//   diffuse bounce (PATH_RAY_DIFFUSE: the last bounce, not an earlier one; a transparent pass
//   keeps it, a volume scatter clears it), Reflective off drops glossy reflection closures and
//   Refractive off refraction ones: `lobes` without kRayGlossy / kRayTransmission. A
//   Multiscatter GGX glass is one closure of both: dropped only with both off. The Transparent
//   BSDF is kept.
struct ClosureFilter {
  float blur_alpha = 0.0f;
  uint8_t lobes = kAllLobes;
  bool active() const { return blur_alpha > 0.0f || lobes != kAllLobes; }
};
// `f` applied to the parameters at a point (a mix's components with them, copied).
void filter_closures(BsdfParams& p, const ClosureFilter& f);

// The components of a mix at one shading point: their RGB parameters (with their own parts)
// and, where made for the spectral methods, their colours' spectra, upsampled once per point
// (RgbSpectrum::reflectance_interpolated) however many wavelengths and calls read them.
struct MixComponents {
  BsdfParams a, b;
  bool spectral = false;
  RgbSpectrum spectrum_a, spectrum_b;
};

// The parameters of `m` at a shading point: its constants, the legacy image textures at the
// point's uv, and the inputs linked into its node graph evaluated there (one run of the graph).
// `spectral`: a mix's components also get their colours' spectra (MixComponents).
BsdfParams bsdf_params(const Material& m, const shading::ShadingContext& ctx, bool spectral = false);
// The same where only a texture coordinate is known (graphs see no position: tables, tests).
inline BsdfParams bsdf_params(const Material& m, Vec2 uv) { return bsdf_params(m, shading::ShadingContext::at_uv(uv)); }

class Bsdf {
 public:
  // The BSDF of material m at surface texture coordinate uv (SurfaceHit::uv).
  Bsdf(const Material& m, Vec2 uv) : Bsdf(m, shading::ShadingContext::at_uv(uv)) {}
  // The BSDF of material m at a shading point (Scene::bsdf builds it from a hit).
  Bsdf(const Material& m, const shading::ShadingContext& ctx) : p_(bsdf_params(m, ctx)), ctx_(ctx) { salt_walks(); }
  // An untextured material's BSDF (tests, tables): its textures, if any, are read at uv (0, 0).
  explicit Bsdf(const Material& m) : Bsdf(m, Vec2()) {}
  // A BSDF of parameters already looked up (the spectral integrators' per-wavelength ones);
  // uv is where a mix's components look up their textures.
  explicit Bsdf(const BsdfParams& p, Vec2 uv = Vec2()) : p_(p), ctx_(shading::ShadingContext::at_uv(uv)) { salt_walks(); }
  Bsdf(const BsdfParams& p, const shading::ShadingContext& ctx) : p_(p), ctx_(ctx) { salt_walks(); }

  // `lobes` (kRay* bits) restricts both to the lobes of those kinds: what a light visible to
  // only some kinds of bounce ray lights by next-event estimation, and the density with which
  // BSDF sampling reaches it through those lobes (its MIS weight).
  RGB eval(const Vec3& wo, const Vec3& wi, TransportMode mode = TransportMode::Radiance,
           uint8_t lobes = kAllLobes) const;
  float pdf(const Vec3& wo, const Vec3& wi, uint8_t lobes = kAllLobes) const;
  // Cycles' density of reaching wi through the closures of kinds `lobes`: it picks a Mix's (or
  // an Add's) components in proportion to their sample weights (closure_weight) where sample()
  // picks them by the mix factor alone; other materials' lobes keep pdf()'s split. What a
  // World hidden from some kinds lights depends on it (integrators/lobe_split.h).
  float closure_pdf(const Vec3& wo, const Vec3& wi, uint8_t lobes = kAllLobes) const;
  // uc picks the lobe (reflection/transmission), u the direction.
  std::optional<BsdfSample> sample(const Vec3& wo, float uc, Vec2 u,
                                   TransportMode mode = TransportMode::Radiance) const;

  // True when every lobe is a Dirac delta (conductor/dielectric with roughness < kSmoothAlpha,
  // or a dielectric of IOR 1, which only passes light straight through): eval/pdf are zero.
  bool is_delta() const;
  // True when a non-Dirac lobe carries light from one side of the surface to the other (a rough
  // dielectric, Translucent, a mix with one): a photon gather there takes both sides' photons
  // (photon_gather_side, integrators/photon/photon_estimate.h). Dirac transmission (smooth glass,
  // a Transparent BSDF) is no such lobe: eval() is zero for it.
  bool transmits() const;
  // True when the BSDF scatters nothing (emission-only material).
  bool is_black() const;
  // Cycles' shader_bsdf_transparency: the summed weights of the material's Transparent BSDF
  // closures (Material::has_transparent_closure) at this point, mix factors included; black
  // for every other closure. What a shadow ray keeps of its light through the surface (in the
  // spectral methods the one wavelength's value, grey).
  RGB transparency() const;
  // True when eval() is a random estimate (a Multiscatter GGX lobe, bsdf.cpp): unbiased, not
  // deterministic in its arguments alone (its stream is keyed by them and the shading point).
  bool is_stochastic() const;
  // Photon-method classification: diffuse when roughness > threshold (GPM §4.3).
  bool is_diffuse_for_photons(float threshold = kDefaultSpecularThreshold) const;
  // Where a normal or bump map bent the shading normal: the geometric normal and the smooth
  // (interpolated, unmapped) normal in the local frame. Then a direction pair on the wrong side
  // of the geometric surface for its lobe (a reflection through the surface, a transmission
  // that stays on one side) scatters nothing, as Cycles does, so a bent normal never lets light
  // through an opaque surface; and diffuse lobes take Cycles' bump shadowing term against the
  // smooth normal (bsdf.cpp).
  void set_surface_normals(const Vec3& ng_local, const Vec3& smooth_local) {
    ng_ = ng_local;
    p_.smooth_normal = smooth_local;
  }
  // The parameters it evaluates (type, IOR, colour at this point).
  const BsdfParams& params() const { return p_; }
  // Cycles' Light Paths > Caustics at this point of a camera path (filter_closures).
  void filter(const ClosureFilter& f) { filter_closures(p_, f); }
  Bsdf component(const Material* m) const;  // a mix's part, with the surface's normals

 private:
  MaterialType kind() const;
  void salt_walks();  // BsdfParams::walk_salt from the shading point (Multiscatter GGX only)
  static bool walks(const Material& m);  // m has a Multiscatter GGX lobe
  BsdfParams p_;
  shading::ShadingContext ctx_;  // where a mix's components read their inputs
  Vec3 ng_{0, 0, 0};  // zero: no geometric-side test (the shading normal is the interpolated one)
  bool wrong_side(const Vec3& wo, const Vec3& wi) const {
    if (ng_.x == 0 && ng_.y == 0 && ng_.z == 0) return false;
    return (dot(wo, ng_) * dot(wi, ng_) > 0) != (wo.z * wi.z > 0);
  }
  RGB eval_lobes(const Vec3& wo, const Vec3& wi, TransportMode mode, uint8_t lobes) const;
  std::optional<BsdfSample> sample_lobes(const Vec3& wo, float uc, Vec2 u, TransportMode mode) const;
};

// Shading-normal correction of the adjoint (importance) BSDF, Veach 1997 eq. 5.20: with world
// directions wo, wi and the geometric and shading normals ng, ns,
// |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|); 0 where it is undefined (a direction in the shading or
// geometric plane). Photon tracing multiplies every scattering by it.
inline float adjoint_shading_correction(const Vec3& wo, const Vec3& wi, const Vec3& ng, const Vec3& ns) {
  const float denom = std::abs(dot(wo, ng)) * std::abs(dot(wi, ns));
  return denom > 0 ? std::abs(dot(wo, ns)) * std::abs(dot(wi, ng)) / denom : 0.0f;
}

// A normal or bump map's correction of a photon density estimate: photons land with a density
// that carries the surface's cosine |wi.n_smooth| (flux through the surface; the interpolated
// normal stands for the surface, as in every photon gather here), where reflected radiance, as
// the path tracer computes it, weighs incident light by the mapped normal's |wi.ns|. Each
// gathered photon takes the ratio (the gather's counterpart of eq. 5.20's correction, Veach
// 1997 §5.3), exactly 1 where no map bent the normal. Not the full ratio to the geometric
// normal: on a coarse smooth-shaded mesh, 1 / |wi.ng| of photons grazing a facet made a
// sphere's PPM image 1.15 of pt with fireflies 40x its brightest pixel; under a map, a diffuse
// lobe's bump shadowing term bounds G |wi.ns| / |wi.n_smooth| by 1 / (ns.n_smooth).
inline float gather_shading_correction(const Vec3& wi, const Vec3& n_smooth, const Vec3& ns) {
  const float cos_smooth = std::abs(dot(wi, n_smooth));
  return cos_smooth > 0 ? std::abs(dot(wi, ns)) / cos_smooth : 0.0f;
}

// Fills the tables a material's BSDF needs (a plastic's coat albedo); the loader calls it for
// every material. A plastic without them falls back to Schlick's Fresnel for the coupling.
inline constexpr int kCoatAlbedoBins = 32;
void prepare_material(Material& m);

// Fresnel reflectance of a dielectric interface for cos_i (signed: < 0 means from inside)
// and relative IOR eta = n_inside / n_outside.
float fresnel_dielectric(float cos_i, float eta);

// The colour of a dielectric's reflection at the signed cosine cos_h of the reflected direction
// to the microfacet (or shading) normal: its colour, or Cycles 3.4's Principled glass's
// (BsdfParams::principled_glass).
RGB dielectric_reflection_color(const BsdfParams& m, float cos_h);

}  // namespace gp
