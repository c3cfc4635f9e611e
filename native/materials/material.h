// The closed material set (DESIGN.md): diffuse, conductor, dielectric, emission-only, plastic
// (a Fresnel-weighted diffuse base under a GGX dielectric coat), principled (Cycles' Principled
// BSDF non-metal: Burley diffuse plus GGX specular, added as Cycles does) and mix/add of two materials (Blender's Mix and Add Shader). A Material is plain parameters,
// some of which an image texture may drive (textures/texture.h); bsdf.h turns it into a BSDF
// at one surface point, evaluated in a local frame.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/spectrum.h"
#include "shading/graph.h"
#include "textures/texture.h"

namespace gp {

// A material input driven by the material's node graph (docs/scene-format.md "Node graphs"):
// where its compiled program leaves the value, read as the input's type. Unlinked: the
// constant (or the legacy TextureRef) holds.
struct GraphInput {
  bool linked = false;
  shading::InputSource source;
  explicit operator bool() const { return linked; }
};

// Translucent: Cycles' Translucent BSDF (Lambertian transmission); Velvet: Cycles' Velvet BSDF
// (Ashikhmin's velvet, sigma in `roughness`). Blender's Transparent BSDF is a Dielectric of IOR 1
// (a tinted pass-through: the loader's "transparent"), its Refraction BSDF a Dielectric with
// `refraction_only`.
// Clearcoat: Cycles 3.4's Principled clearcoat closure on its own (kernel/closure/bsdf_microfacet.h,
// CLOSURE_BSDF_MICROFACET_GGX_CLEARCOAT_ID), which the exporter adds to the rest of a Principled
// BSDF with its own normal: `clearcoat` its Clearcoat input, `roughness` its GTR1 alpha.
enum class MaterialType { Diffuse, Conductor, Dielectric, Emission, Plastic, Principled, Mix, Translucent, Velvet, Clearcoat };

// A conductor's Fresnel factor F(cos_h) at the microfacet:
//   None:       the colour at every angle (Blender's Glossy BSDF);
//   Schlick:    Schlick 1994 with F0 = colour (the scene format's default);
//   Principled: Cycles 3.4's Principled BSDF metal (kernel/closure/bsdf_util.h,
//               interpolate_fresnel_color): F = colour (1 - FH) + FH with
//               FH = (F_d(cos_h, ior) - F_d(1, ior)) / (1 - F_d(1, ior)), F_d the dielectric
//               Fresnel of the Principled lobe's IOR (from its Specular input).
enum class ConductorFresnel : uint8_t { None, Schlick, Principled };

// A glossy conductor's microfacet distribution (Blender's Glossy BSDF / Anisotropic BSDF
// Distribution), Cycles 3.4's maths (kernel/closure/bsdf_microfacet.h,
// bsdf_ashikhmin_shirley.h): GGX; Beckmann (exact D, Smith G1 by Walter et al.'s rational
// approximation, separable G); Ashikhmin-Shirley (exponent 2 / alpha^2 - 2, its "pump"
// normalisation); Multiscatter GGX (Heitz et al. 2016's random walk on the GGX microsurface,
// as Cycles 3.4's bsdf_microfacet_multi.h: its eval is stochastic, bsdf.cpp). Dielectrics take
// GGX, Beckmann and Multiscatter GGX; principled's specular lobe GGX and Multiscatter GGX.
enum class Microfacet : uint8_t { GGX, Beckmann, AshikhminShirley, MultiGGX };

// Default roughness below which a BSDF counts as specular for photon methods
// (gradient-domain photon density estimation §4.3 / §6: "roughness threshold 0.05").
inline constexpr float kDefaultSpecularThreshold = 0.05f;

struct Material {
  std::string name;
  MaterialType type = MaterialType::Diffuse;
  // Diffuse: Lambertian albedo. Conductor: normal-incidence reflectance F0 (Schlick).
  // Dielectric: tint multiplying reflection and transmission (white = clear glass).
  RGB color{0.8f};
  // GGX alpha (Mitsuba's convention; Blender's roughness r maps to alpha = r^2).
  // 0 = perfectly smooth (delta) conductor or dielectric.
  // Diffuse: Blender's Roughness itself, the Oren-Nayar sigma (0: Lambertian).
  float roughness = 0.0f;
  // Conductor: how its reflectance varies with the angle (ConductorFresnel; Principled uses `ior`).
  ConductorFresnel conductor_fresnel = ConductorFresnel::Schlick;
  Microfacet distribution = Microfacet::GGX;  // conductor, dielectric, principled: the microfacet distribution
  // Cycles 3.4's singular closures (Reflection, Refraction, Sharp Glass): roughness 0, and left
  // sharp by Filter Glossy (bsdf.h ClosureFilter), where GGX at 0 is blurred. Blender's Sharp
  // distribution compiles to them only when its Roughness input is linked to a varying value;
  // an unlinked one is GGX at 0 once Filter Glossy is on (shader_nodes.cpp simplify_settings).
  bool sharp = false;
  // Plastic: `color` is the diffuse albedo, `roughness` the coat's GGX alpha, `ior` the coat's.
  // Principled (Cycles 3.4's Principled BSDF, non-metal): `color` the base colour, `roughness`
  // the specular lobe's GGX alpha (its square root drives the diffuse retro-reflection), `ior`
  // the specular lobe's (from Blender's Specular s: F0 = 0.08 s).
  // Conductor with Principled Fresnel: the IOR of the dielectric Fresnel it interpolates with.
  float ior = 1.5f;       // dielectric: interior IOR (Cauchy A) over an outside of 1
  // Principled (Cycles 3.4's svm_closure.h, CLOSURE_BSDF_PRINCIPLED_ID): Specular Tint tints
  // the specular lobe's normal-incidence reflectance toward the base colour's hue; Sheen adds
  // Burley's sheen lobe of colour mix(1, hue, Sheen Tint) (bsdf_principled_sheen.h).
  float specular_tint = 0.0f, sheen = 0.0f, sheen_tint = 0.5f;
  // Clearcoat: Blender's Clearcoat input (the lobe's weight is 0.25 clearcoat x Fresnel).
  float clearcoat = 0.0f;
  // Conductor and principled (their GGX or Beckmann lobe): Cycles 3.4's Anisotropic BSDF
  // Anisotropy an in [-0.99, 0.99] (svm_closure.h): alpha_x = alpha (1 - an), alpha_y = alpha /
  // (1 - an) for an >= 0, alpha_x = alpha / (1 + an), alpha_y = alpha (1 + an) below, alpha_x
  // along the tangent; the exporter writes Principled's Anisotropic in this convention. The
  // tangent (`tangent_in`, else Cycles' default: the radial tangent about the object's Z axis)
  // turned by `rotation` x 2 pi about the normal is the shading frame's first axis
  // (Scene::surface_hit), so the BSDF sees it as local x.
  float anisotropy = 0.0f, rotation = 0.0f;
  float cauchy_b = 0.0f;  // Cauchy B in um^2: n(lambda) = A + B / lambda^2 (spectral mode)
  // Dielectric: only the refraction lobe, without Fresnel weighting (Cycles 3.4's Refraction
  // BSDF: all light refracts, none reflects; total internal reflection absorbs).
  bool refraction_only = false;
  // Dielectric: Cycles 3.4's Glass BSDF (GGX, Beckmann, Sharp) as its SVM builds it
  // (svm/closure.h): a reflection closure and a refraction-only closure, neither with a Fresnel
  // of its own, weighted by F and 1 - F, F the dielectric Fresnel at the shading normal for the
  // direction toward the camera (fresnel_dielectric_cos(dot(N, I), eta)). Off: Walter et al.'s
  // Fresnel per microfacet (the scene format's default; Multiscatter GGX glass is one closure
  // with its own per-microfacet Fresnel in Cycles too and ignores this).
  bool fresnel_at_normal = false;
  // Dielectric: Cycles 3.4's Principled glass (svm/closure.h): the colour tints the refraction
  // only; the reflection is white blended toward the colour by specular_tint through Cycles'
  // interpolate_fresnel_color (bsdf.cpp dielectric_reflection_color). Off: the colour tints
  // both (Blender's Glass BSDF; the scene format's default).
  bool principled_glass = false;
  // Conductor and principled GGX lobes: Smith's masking-shadowing as the separable G1(wo) G1(wi)
  // (Cycles 3.4's bsdf_microfacet.h, what the Blender exporter writes) instead of the
  // height-correlated G ([Heitz14] eq. 99, the scene format's default). Anisotropic GGX is
  // separable either way, Beckmann always is, Multiscatter GGX's walk is its own.
  bool separable_masking = false;
  // Emitted radiance (W sr^-1 m^-2) = emission * strength; any type may emit.
  RGB emission{0.0f};
  float emission_strength = 0.0f;
  bool two_sided = false;  // emission from both faces; one-sided emits along the geometric normal
  // Line emission spectrum (scene format "spectrum"): empty = the smooth spectrum of `emission`.
  // When set, `emission` holds the lines' RGB at luminance 1 (spectral_lines_rgb), so
  // radiance() is the RGB-mode colour and strength the luminance.
  std::vector<SpectralLine> emission_lines;
  float emission_fwhm = 1.0f;  // nm
  // Ray visibility, as Cycles' object Visibility panel: camera rays pass through a surface that
  // is not visible to the camera; shadow rays pass through one that casts no shadow. A Blender
  // light object is an emissive pass-through (dielectric of IOR 1) with both off.
  // Mix: (1 - mix_factor) a + mix_factor b; with mix_add, a + b (Blender's Add Shader). The
  // components are copies (resolved by name when the scene loads), so a Material stays
  // self-contained. Emission and visibility are the mix's own, not the components'.
  std::shared_ptr<const Material> mix_a, mix_b;
  // Plastic: the coat's directional albedo E(cos theta) at kCoatAlbedoBins + 1 evenly spaced
  // cosines, then its cosine-weighted average; filled by prepare_material() (bsdf.h).
  std::shared_ptr<const std::vector<float>> coat_albedo;
  float mix_factor = 0.5f;
  bool mix_add = false;
  bool visible_to_camera = true;
  bool casts_shadow = true;
  // Cycles' holdout (object Mask > Holdout, the Holdout shader): a camera ray that meets this
  // surface ends there with no colour and alpha 0 (CameraRays); other rays see it as it is.
  bool holdout = false;
  // A Holdout closure weighted inside a Mix / Add Shader (Cycles 3.4: svm_node_closure_holdout
  // allocates it with its mix weight, shader_holdout_apply sums those weights, and
  // integrate_surface_holdout adds weight x throughput to the pixel's transparency): a camera ray
  // that meets the surface covers its pixel by 1 - weight (CameraRays::coverage) and goes on; the
  // colour is the mix's other closures', which the holdout's black component already scales.
  // holdout_in: the weight from the node graph (clamped to [0, 1]).
  float holdout_weight = 0.0f;
  // Cycles' Diffuse / Glossy / Transmission switches: the kinds of bounce ray (kRay* bits of
  // the lobe that sampled them) that see this surface, and whose lobes its emission lights by
  // next-event estimation. Honoured by the path tracer (docs/blender.md).
  uint8_t visible_lobes = kAllLobes;
  // The participating medium inside a closed mesh of this material (Scene::media; -1: none),
  // entered through the front face (Blender's material Volume output). A material with a
  // volume and no surface (scene format "type": "volume") is a pass-through boundary.
  int interior = -1;

  // ---- Textured inputs (an empty TextureRef: the constant above) ----
  // Looked up at the hit's uv by Bsdf (colour, roughness, mix factor; in a mix, each
  // component's own) and by the scene (normal map, bump: the top-level material's). (The scene
  // format's `alpha` is a Mix with a Transparent BSDF, made by the loader: scene/loader.cpp.)
  TextureRef color_tex;      // replaces `color`
  TextureRef roughness_tex;  // replaces `roughness` (GGX alpha)
  TextureRef factor_tex;     // replaces `mix_factor`
  // Tangent-space normal map (Blender's Normal Map node): n = normalize(2 c - 1) in the frame
  // (tangent, bitangent, shading normal), blended toward the shading normal by strength.
  TextureRef normal_tex;
  float normal_strength = 1.0f;
  // Bump map (Blender's Bump node): the surface displaced by distance * height along the normal,
  // blended by strength.
  TextureRef bump_tex;
  float bump_strength = 1.0f, bump_distance = 1.0f;

  // ---- Node graph (shading/graph.h): the program compiled from the material's `nodes`, and
  // the inputs linked into it (read per shading point by bsdf_params and the scene) ----
  std::shared_ptr<const shading::ShaderProgram> graph;
  GraphInput color_in, roughness_in, factor_in, ior_in, normal_in, emission_in, strength_in, holdout_in;
  GraphInput specular_tint_in, sheen_in, sheen_tint_in, clearcoat_in;  // principled / clearcoat
  GraphInput anisotropy_in, rotation_in, tangent_in;  // anisotropic lobes

  bool has_bsdf_textures() const {
    return color_tex || roughness_tex || factor_tex || color_in || roughness_in || factor_in || ior_in ||
           specular_tint_in || sheen_in || sheen_tint_in || clearcoat_in || anisotropy_in ||
           (mix_a && mix_a->has_bsdf_textures()) || (mix_b && mix_b->has_bsdf_textures());
  }
  // The part of the material whose tangent orients the shading frame: itself, or the first
  // anisotropic component of a mix (null: isotropic everywhere).
  const Material* anisotropic_part() const {
    if ((type == MaterialType::Conductor || type == MaterialType::Principled) && (anisotropy != 0.0f || anisotropy_in))
      return this;
    if (type != MaterialType::Mix) return nullptr;
    if (const Material* a = mix_a ? mix_a->anisotropic_part() : nullptr) return a;
    return mix_b ? mix_b->anisotropic_part() : nullptr;
  }
  bool perturbs_normal() const { return normal_tex || bump_tex || normal_in; }
  // Whether a node graph this material runs (its own, a mix component's) reads the surface
  // tangents dPdu / dPdv: where none does, the shading context leaves them out.
  bool graph_reads_tangents() const {
    return (graph && graph->reads_tangents()) || (mix_a && mix_a->graph_reads_tangents()) ||
           (mix_b && mix_b->graph_reads_tangents());
  }
  // Whether shading it runs a node graph (its own, a mix component's): such a material needs the
  // hit's whole shading context (position, object, tangents), not its uv alone.
  bool runs_graph() const { return graph || (mix_a && mix_a->runs_graph()) || (mix_b && mix_b->runs_graph()); }
  bool holds_out_partly() const { return !holdout && (holdout_weight > 0.0f || holdout_in); }
  bool emission_from_graph() const { return emission_in || strength_in; }

  // The constant emission (a graph-driven one: its average over the surface, set by the scene).
  RGB radiance() const { return emission * emission_strength; }
  // A surface light passes straight through unchanged: a clear dielectric of IOR 1 (how a
  // Blender light object is exported, as Cycles' lights are not geometry).
  bool is_pass_through() const {
    return type == MaterialType::Dielectric && ior == 1.0f && cauchy_b == 0.0f && color.r == 1.0f &&
           color.g == 1.0f && color.b == 1.0f;
  }
  bool is_emissive() const { return !radiance().is_black(); }
  // Whether a Transparent BSDF closure (a smooth dielectric of IOR 1, any colour) is part of the
  // material, alone or in a Mix / Add: shadow rays then pass through it, filtered by the
  // closure's weight at the hit (Cycles' SD_HAS_TRANSPARENT_SHADOW; Bsdf::transparency,
  // paths/medium_walk.h ShadowTest). A light object's pass-through casts no shadow at all.
  bool has_transparent_closure() const {
    if (type == MaterialType::Dielectric)
      return ior == 1.0f && roughness == 0.0f && !refraction_only && cauchy_b == 0.0f && !ior_in && !roughness_tex &&
             !roughness_in;
    return type == MaterialType::Mix &&
           ((mix_a && mix_a->has_transparent_closure()) || (mix_b && mix_b->has_transparent_closure()));
  }
  bool transparent_shadow() const { return casts_shadow && has_transparent_closure(); }
};

inline const char* to_string(MaterialType t) {
  switch (t) {
    case MaterialType::Diffuse: return "diffuse";
    case MaterialType::Conductor: return "conductor";
    case MaterialType::Dielectric: return "dielectric";
    case MaterialType::Emission: return "emission";
    case MaterialType::Plastic: return "plastic";
    case MaterialType::Principled: return "principled";
    case MaterialType::Mix: return "mix";
    case MaterialType::Translucent: return "translucent";
    case MaterialType::Velvet: return "velvet";
    case MaterialType::Clearcoat: return "clearcoat";
  }
  return "?";
}

}  // namespace gp
