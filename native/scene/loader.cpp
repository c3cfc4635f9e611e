// JSON scene loader. The format is documented in docs/scene-format.md; keep the two in step.
//
// Every value is read through a helper that knows its JSON path ("/objects/3/radius"), so a
// wrong value fails with SceneError("<file>: <path>: <what is wrong>"). Keys a reader does not
// know are counted warnings ("unknown key"), the way pbrt reports unused parameters.
#include "scene/loader.h"

#include "materials/bsdf.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string_view>
#include <unordered_map>

#include "core/memory.h"
#include "shading/graph.h"
#include "lights/sky.h"
#include "lights/world_graph.h"
#include "scene/json_reader.h"
#include "scene/obj_mesh.h"
#include "scene/shapes.h"
#include "media/vdb_file.h"
#include "textures/texture_store.h"

namespace gp {

namespace {

// What one triangle of a tessellated shape costs once the scene is built: the mesh arrays
// (about half a vertex of position, normal and uv per triangle, three indices, a material id)
// and Embree's BVH, measured on a 2 M-triangle torus (docs/reliability.md) and rounded up.
constexpr double kBytesPerTriangle = 160;

class Loader : private JsonReader {
 public:
  Loader(std::string file, std::string base_dir, Scene& scene)
      : JsonReader(std::move(file), scene.warnings), base_dir_(std::move(base_dir)), scene_(scene) {}

  void load(const json& root) {
    if (!root.is_object()) fail("", fmt::format("the scene must be a JSON object, not {}", root.type_name()));
    check_keys(root, "", {"description", "camera", "media", "materials", "objects", "lights", "environment",
                          "world_medium", "volume_bounces", "transparent_bounces", "filter_glossy",
                          "caustics_reflective", "caustics_refractive"});
    if (const json* d = find(root, "description")) get_string(*d, "/description");
    if (const json* m = find(root, "media")) load_media(*m, "/media");
    if (const json* w = find(root, "world_medium")) scene_.world_medium = medium_by_name(*w, "/world_medium");
    if (const json* v = find(root, "volume_bounces")) scene_.volume_bounces = int(get_int(*v, "/volume_bounces", 0, 1 << 20));
    // Light Paths > Max Bounces > Transparent (Blender's range 0-1024; Cycles' default 8).
    if (const json* v = find(root, "transparent_bounces"))
      scene_.transparent_bounces = int(get_int(*v, "/transparent_bounces", 0, 1024));
    // Light Paths > Caustics (Scene::filter_glossy; Blender's Filter Glossy range 0-10).
    if (const json* v = find(root, "filter_glossy")) scene_.filter_glossy = get_in_range(*v, "/filter_glossy", 0.0f, 10.0f);
    if (const json* v = find(root, "caustics_reflective")) scene_.caustics_reflective = get_bool(*v, "/caustics_reflective");
    if (const json* v = find(root, "caustics_refractive")) scene_.caustics_refractive = get_bool(*v, "/caustics_refractive");
    if (const json* m = find(root, "materials")) load_materials(*m, "/materials");
    if (const json* c = find(root, "camera")) load_camera(*c, "/camera");
    if (const json* o = find(root, "objects")) {
      require_array(*o, "/objects");
      for (size_t i = 0; i < o->size(); ++i) load_object((*o)[i], sub("/objects", i));
    }
    if (const json* l = find(root, "lights")) {
      require_array(*l, "/lights");
      for (size_t i = 0; i < l->size(); ++i) load_light((*l)[i], sub("/lights", i));
    }
    if (const json* e = find(root, "environment")) load_environment(*e, "/environment");
  }

 private:
  // ---- Materials ----

  void load_materials(const json& mats, const std::string& path) {
    require_object(mats, path);
    for (auto it = mats.begin(); it != mats.end(); ++it) {
      const std::string mpath = sub(path, it.key());
      const json& m = it.value();
      require_object(m, mpath);
      Material mat;
      mat.name = it.key();
      const std::string type = get_string(need(m, "type", mpath), sub(mpath, "type"));
      std::vector<std::string_view> keys = {"type", "emission", "strength", "two_sided", "spectrum",
                                            "visible_to_camera", "casts_shadow", "visible_to_diffuse",
                                            "visible_to_glossy", "visible_to_transmission", "alpha", "normal_map",
                                            "bump", "nodes", "normal", "holdout", "interior"};
      if (type == "diffuse") {
        mat.type = MaterialType::Diffuse;
        keys.insert(keys.end(), {"color", "roughness"});  // roughness: Oren-Nayar sigma (bsdf.cpp)
      } else if (type == "conductor") {
        mat.type = MaterialType::Conductor;
        keys.insert(keys.end(), {"color", "roughness", "fresnel", "ior", "distribution", "masking"});
        if (const json* f = find(m, "fresnel")) mat.conductor_fresnel = load_conductor_fresnel(*f, sub(mpath, "fresnel"));
      } else if (type == "dielectric") {
        mat.type = MaterialType::Dielectric;
        mat.color = RGB(1.0f);
        keys.insert(keys.end(), {"color", "ior", "roughness", "cauchy_b", "abbe", "distribution", "fresnel",
                                 "specular_tint"});
        // "specular_tint" (Cycles 3.4's Principled glass, Material::principled_glass): its presence
        // leaves the reflection white, tinted toward "color" by its value (a link: load_graph_inputs).
        if (const json* v = find(m, "specular_tint")) {
          mat.principled_glass = true;
          if (!shading::is_link(*v)) mat.specular_tint = get_in_range(*v, sub(mpath, "specular_tint"), 0.0f, 1.0f);
        }
        // "fresnel": "microfacet" (Walter et al.'s, the default) or "normal" (Cycles 3.4's Glass
        // BSDF split, Material::fresnel_at_normal).
        if (const json* f = find(m, "fresnel")) {
          const std::string fpath = sub(mpath, "fresnel");
          const std::string v = get_string(*f, fpath);
          if (v == "normal") mat.fresnel_at_normal = true;
          else if (v != "microfacet")
            fail(fpath, fmt::format("unknown dielectric Fresnel '{}' (known: \"microfacet\", \"normal\")", v));
        }
      } else if (type == "transparent") {
        // Blender's Transparent BSDF: straight through, tinted: a smooth dielectric of IOR 1.
        mat.type = MaterialType::Dielectric;
        mat.color = RGB(1.0f);
        mat.ior = 1.0f;
        keys.push_back("color");
      } else if (type == "volume") {
        // A volume and no surface (Blender's Volume-only material): a pass-through boundary of
        // its interior medium that casts no shadow (a light object's surface, paths/camera_path.h).
        mat.type = MaterialType::Dielectric;
        mat.color = RGB(1.0f);
        mat.ior = 1.0f;
        mat.casts_shadow = false;
        need(m, "interior", mpath);
      } else if (type == "refraction") {
        // Blender's Refraction BSDF: the refraction lobe of glass alone, without Fresnel.
        mat.type = MaterialType::Dielectric;
        mat.color = RGB(1.0f);
        mat.refraction_only = true;
        keys.insert(keys.end(), {"color", "ior", "roughness", "distribution"});
      } else if (type == "translucent") {
        mat.type = MaterialType::Translucent;
        keys.push_back("color");
      } else if (type == "velvet") {
        // Blender's Velvet BSDF: "sigma" (its Sigma input, default 1) is kept in roughness.
        mat.type = MaterialType::Velvet;
        mat.roughness = 1.0f;
        keys.insert(keys.end(), {"color", "sigma"});
        if (const json* g = find(m, "sigma")) mat.roughness = get_in_range(*g, sub(mpath, "sigma"), 0.0f, 1.0f);
      } else if (type == "emission") {
        mat.type = MaterialType::Emission;
        mat.emission = RGB(1.0f);
      } else if (type == "plastic" || type == "principled") {
        mat.type = type == "plastic" ? MaterialType::Plastic : MaterialType::Principled;
        keys.insert(keys.end(), {"color", "roughness", "ior"});
        if (type == "principled") keys.insert(keys.end(), {"distribution", "masking"});
        if (type == "principled") {
          // Cycles' Specular Tint, Sheen and Sheen Tint (constants here; links: load_graph_inputs).
          keys.insert(keys.end(), {"specular_tint", "sheen", "sheen_tint"});
          if (const json* v = find(m, "specular_tint"); v && !shading::is_link(*v))
            mat.specular_tint = get_in_range(*v, sub(mpath, "specular_tint"), 0.0f, 1.0f);
          if (const json* v = find(m, "sheen"); v && !shading::is_link(*v))
            mat.sheen = get_nonnegative(*v, sub(mpath, "sheen"));
          if (const json* v = find(m, "sheen_tint"); v && !shading::is_link(*v))
            mat.sheen_tint = get_in_range(*v, sub(mpath, "sheen_tint"), 0.0f, 1.0f);
        }
      } else if (type == "clearcoat") {
        // Cycles' Principled clearcoat closure: "clearcoat" its weight input, "roughness" its
        // GTR1 alpha (Blender's Clearcoat Roughness squared).
        mat.type = MaterialType::Clearcoat;
        mat.color = RGB(1.0f);
        mat.clearcoat = 1.0f;
        keys.insert(keys.end(), {"clearcoat", "roughness"});
        if (const json* v = find(m, "clearcoat"); v && !shading::is_link(*v))
          mat.clearcoat = get_nonnegative(*v, sub(mpath, "clearcoat"));
      } else if (type == "mix" || type == "add") {
        mat.type = MaterialType::Mix;
        mat.mix_add = type == "add";
        keys.insert(keys.end(), {"a", "b"});
        if (type == "mix") keys.push_back("factor");
        // Components are names of other materials, resolved once all are read.
        mix_refs_.push_back({scene_.materials.size(), get_string(need(m, "a", mpath), sub(mpath, "a")),
                             get_string(need(m, "b", mpath), sub(mpath, "b")), mpath});
        if (const json* f = find(m, "factor"); f && !shading::is_link(*f)) {
          if (is_texture(*f)) mat.factor_tex = load_texture_ref(*f, sub(mpath, "factor"), false, {}, &mat.mix_factor);
          else mat.mix_factor = get_in_range(*f, sub(mpath, "factor"), 0.0f, 1.0f);
        }
      } else {
        fail(sub(mpath, "type"),
             fmt::format("unknown material type '{}' (known: diffuse, conductor, dielectric, emission, plastic, "
                         "principled, clearcoat, mix, add, transparent, refraction, translucent, velvet, volume)", type));
      }
      if (const json* k = find(m, "masking"); k && std::find(keys.begin(), keys.end(), "masking") != keys.end()) {
        // "correlated" (the height-correlated Smith G, the default) or "separable" (Cycles 3.4's
        // G1 G1, Material::separable_masking).
        const std::string kpath = sub(mpath, "masking"), v = get_string(*k, kpath);
        if (v == "separable") mat.separable_masking = true;
        else if (v != "correlated")
          fail(kpath, fmt::format("unknown masking '{}' (known: \"correlated\", \"separable\")", v));
      }
      if (const json* d = find(m, "distribution"); d && std::find(keys.begin(), keys.end(), "distribution") != keys.end()) {
        // Blender's microfacet distributions (material.h Microfacet), those each closure has in
        // Cycles 3.4: Glossy all four, Glass GGX / Beckmann / Multiscatter GGX, Refraction GGX /
        // Beckmann, Principled GGX / Multiscatter GGX.
        const std::string dpath = sub(mpath, "distribution"), v = get_string(*d, dpath);
        std::vector<std::pair<std::string_view, Microfacet>> known = {{"ggx", Microfacet::GGX}};
        if (type == "conductor" || type == "dielectric" || type == "refraction") known.push_back({"sharp", Microfacet::GGX});
        if (type != "principled") known.push_back({"beckmann", Microfacet::Beckmann});
        if (type == "conductor") known.push_back({"ashikhmin_shirley", Microfacet::AshikhminShirley});
        if (type != "refraction") known.push_back({"multi_ggx", Microfacet::MultiGGX});
        auto it2 = std::find_if(known.begin(), known.end(), [&](const auto& k) { return k.first == v; });
        if (it2 == known.end()) {
          std::string names;
          for (const auto& k : known) names += (names.empty() ? "" : ", ") + std::string(k.first);
          fail(dpath, fmt::format("unknown distribution '{}' for a {} (known: {})", v, type, names));
        }
        mat.distribution = it2->second;
        // "sharp": roughness 0 whatever is given (below), Cycles' singular closure (Material::sharp: a
        // Blender Sharp with its Roughness linked; an unlinked one exports as GGX at 0).
        mat.sharp = v == "sharp";
      }
      if (type == "conductor" || type == "principled") {
        // Anisotropy (Cycles' Anisotropic BSDF convention), its rotation (turns) and tangent.
        keys.insert(keys.end(), {"anisotropy", "rotation", "tangent"});
        if (const json* v = find(m, "anisotropy"); v && !shading::is_link(*v))
          mat.anisotropy = std::clamp(get_in_range(*v, sub(mpath, "anisotropy"), -1.0f, 1.0f), -0.99f, 0.99f);
        if (const json* v = find(m, "rotation"); v && !shading::is_link(*v)) mat.rotation = get_float(*v, sub(mpath, "rotation"));
        if (const json* t = find(m, "tangent"); t && !shading::is_link(*t))
          fail(sub(mpath, "tangent"), "expected a link into 'nodes' (a Tangent node's output, or any vector)");
      }
      for (auto k = m.begin(); k != m.end(); ++k)
        if (std::find(keys.begin(), keys.end(), std::string_view(k.key())) == keys.end())
          scene_.warnings.add("unknown key", fmt::format("{}: {}", file_, sub(mpath, k.key())));
      // Textured inputs keep their texture's mean in the constant (spectral modes, mix fallbacks).
      // ---- Inputs linked into the material's node graph (docs/scene-format.md "Node graphs") ----
      PendingAlpha alpha{.index = scene_.materials.size(), .path = sub(mpath, "alpha")};
      load_graph_inputs(m, mpath, mat, &alpha.in);
      if (const json* c = find(m, "color"); c && !shading::is_link(*c)) {
        if (is_texture(*c)) mat.color_tex = load_texture_ref(*c, sub(mpath, "color"), true, {}, nullptr, &mat.color);
        else mat.color = get_color(*c, sub(mpath, "color"));
      }
      if (const json* r = find(m, "roughness"); r && !shading::is_link(*r)) {
        if (is_texture(*r)) mat.roughness_tex = load_texture_ref(*r, sub(mpath, "roughness"), false, {}, &mat.roughness);
        else mat.roughness = get_in_range(*r, sub(mpath, "roughness"), 0.0f, 1.0f);
        mat.roughness = std::min(mat.roughness, 1.0f);
      }
      if (mat.sharp) {
        mat.roughness = 0.0f;
        mat.roughness_tex = TextureRef();
      }
      if (const json* a = find(m, "alpha"); a && !shading::is_link(*a)) {
        if (is_texture(*a)) alpha.tex = load_texture_ref(*a, sub(mpath, "alpha"), false, {});
        else alpha.value = get_in_range(*a, sub(mpath, "alpha"), 0.0f, 1.0f);
      }
      if (const json* n = find(m, "normal_map")) {
        const std::string npath = sub(mpath, "normal_map");
        mat.normal_tex = load_texture_ref(*n, npath, true, {"strength"}, nullptr, nullptr, "Non-Color");
        if (const json* s = find(*n, "strength")) mat.normal_strength = get_nonnegative(*s, sub(npath, "strength"));
      }
      if (const json* b = find(m, "bump")) {
        const std::string bpath = sub(mpath, "bump");
        mat.bump_tex = load_texture_ref(*b, bpath, false, {"strength", "distance"}, nullptr, nullptr, "Non-Color");
        if (const json* s = find(*b, "strength")) mat.bump_strength = get_nonnegative(*s, sub(bpath, "strength"));
        if (const json* d = find(*b, "distance")) mat.bump_distance = get_float(*d, sub(bpath, "distance"));
      }
      if (const json* n = find(m, "ior"); n && !shading::is_link(*n)) mat.ior = get_positive(*n, sub(mpath, "ior"));
      if (find(m, "cauchy_b") && find(m, "abbe")) fail(mpath, "give either 'cauchy_b' or 'abbe', not both");
      if (const json* b = find(m, "cauchy_b")) mat.cauchy_b = get_nonnegative(*b, sub(mpath, "cauchy_b"));
      if (const json* v = find(m, "abbe")) {
        // Abbe number V = (n_d - 1) / (n_F - n_C); with Cauchy n = A + B / lambda^2 and
        // n_d = ior: B = (n_d - 1) / V / (1 / lambda_F^2 - 1 / lambda_C^2), lambdas in um.
        const float abbe = get_positive(*v, sub(mpath, "abbe"));
        constexpr double kLambdaF = 0.4861, kLambdaC = 0.6563;
        const double denom = 1.0 / (kLambdaF * kLambdaF) - 1.0 / (kLambdaC * kLambdaC);
        mat.cauchy_b = static_cast<float>((mat.ior - 1.0) / abbe / denom);
        if (mat.cauchy_b < 0) fail(sub(mpath, "abbe"), "needs ior >= 1 (dispersion from an Abbe number)");
      }
      if (type == "transparent") {  // its ior / roughness / dispersion keys are unknown (warned) and ignored
        mat.ior = 1.0f;
        mat.roughness = 0.0f;
        mat.roughness_tex = TextureRef();
        mat.cauchy_b = 0.0f;
      }
      if (mat.distribution == Microfacet::MultiGGX && mat.cauchy_b != 0.0f) {
        // The spectral methods follow one walk for every wavelength; a dispersive walk's
        // direction depends on the wavelength and its density is unknown (bsdf.cpp).
        scene_.warnings.add("dispersive Multiscatter GGX glass rendered as GGX", fmt::format("{}: {}", file_, mpath));
        mat.distribution = Microfacet::GGX;
      }
      if (const json* e = find(m, "emission"); e && !shading::is_link(*e)) mat.emission = get_color(*e, sub(mpath, "emission"));
      mat.emission_strength = 1.0f;
      if (const json* s = find(m, "strength"); s && !shading::is_link(*s)) mat.emission_strength = get_nonnegative(*s, sub(mpath, "strength"));
      if (const json* t = find(m, "two_sided")) mat.two_sided = get_bool(*t, sub(mpath, "two_sided"));
      if (const json* v = find(m, "visible_to_camera")) mat.visible_to_camera = get_bool(*v, sub(mpath, "visible_to_camera"));
      if (const json* v = find(m, "casts_shadow")) mat.casts_shadow = get_bool(*v, sub(mpath, "casts_shadow"));
      // true (the whole surface), a weight in [0, 1] (a Holdout closure in a mix; 1 is true) or a
      // link into the node graph (holdout_in).
      if (const json* v = find(m, "holdout"); v && !shading::is_link(*v)) {
        if (v->is_boolean()) mat.holdout = get_bool(*v, sub(mpath, "holdout"));
        else mat.holdout_weight = get_in_range(*v, sub(mpath, "holdout"), 0.0f, 1.0f);
        if (mat.holdout_weight >= 1.0f) mat.holdout = true;
      }
      if (const json* i = find(m, "interior")) mat.interior = medium_by_name(*i, sub(mpath, "interior"));
      mat.visible_lobes = load_visible_lobes(m, mpath);
      if (mat.type != MaterialType::Emission && !find(m, "emission")) mat.emission = RGB(0.0f);
      if (mat.emission_in && !find(m, "strength")) mat.emission_strength = 1.0f;
      if (const json* sp = find(m, "spectrum")) {
        if (find(m, "emission")) fail(mpath, "give either 'emission' (a colour) or 'spectrum', not both");
        load_spectrum(*sp, sub(mpath, "spectrum"), mat.emission_lines, mat.emission_fwhm);
        mat.emission = spectral_lines_rgb(mat.emission_lines, mat.emission_fwhm);  // luminance 1
      }
      prepare_material(mat);
      if (alpha.value < 1.0f || alpha.tex || alpha.in) pending_alpha_.push_back(std::move(alpha));
      material_index_[mat.name] = static_cast<uint32_t>(scene_.materials.size());
      scene_.materials.push_back(std::move(mat));
    }
    // Mix components: copies of the named materials (a mix of mixes resolves depth first; a
    // cycle is an error).
    std::vector<int> state(scene_.materials.size(), 0);  // 0 unresolved, 1 resolving, 2 done
    for (const MixRef& r : mix_refs_) resolve_mix(r, state);
    // `alpha` last, on the resolved material (a component copied into a mix keeps none, as
    // before: alpha is the whole material's).
    for (const PendingAlpha& a : pending_alpha_) apply_alpha(a);
  }

  // ---- `alpha`: Cycles' Principled Alpha, a Mix Shader of a Transparent BSDF (weight 1 - alpha)
  // and the rest (weight alpha) with the emission inside (Cycles 3.4 shader_nodes.cpp
  // PrincipledBsdfNode::expand). The material becomes that mix, so every method treats it as any
  // Mix with a Transparent BSDF: paths pick the transparent closure by its weight (a transparent
  // bounce), shadow rays pass filtered by it. (It was a stochastic coverage cut-out.) ----
  struct PendingAlpha {
    size_t index = 0;
    std::string path;
    float value = 1.0f;
    TextureRef tex;
    GraphInput in;
  };
  std::vector<PendingAlpha> pending_alpha_;

  void apply_alpha(const PendingAlpha& a) {
    Material& m = scene_.materials[a.index];
    // The opaque part: the material's closures, without what is the whole surface's.
    Material opaque = m;
    opaque.name = m.name + "/~opaque";
    opaque.emission = RGB(0.0f);
    opaque.emission_lines.clear();
    opaque.emission_in = opaque.strength_in = GraphInput();
    opaque.visible_to_camera = opaque.casts_shadow = true;
    opaque.holdout = false;
    opaque.holdout_weight = 0.0f;
    opaque.holdout_in = GraphInput();
    opaque.interior = -1;
    opaque.visible_lobes = kAllLobes;
    opaque.normal_tex = opaque.bump_tex = TextureRef();
    Material clear;  // a white Transparent BSDF (the loader's "transparent")
    clear.name = m.name + "/~transparent";
    clear.type = MaterialType::Dielectric;
    clear.color = RGB(1.0f);
    clear.ior = 1.0f;
    Material mix;
    mix.name = m.name;
    mix.type = MaterialType::Mix;
    mix.mix_factor = a.value;
    mix.factor_tex = a.tex;
    mix.factor_in = a.in;
    mix.graph = m.graph;
    mix.roughness = opaque.roughness;
    mix.color = opaque.color * a.value + RGB(1.0f - a.value);  // the fallback colour, as resolve_mix's
    // Emission is inside the mix in Cycles: weighted by alpha.
    mix.emission = m.emission;
    mix.emission_lines = m.emission_lines;
    mix.emission_fwhm = m.emission_fwhm;
    mix.emission_strength = m.emission_strength * a.value;
    mix.emission_in = m.emission_in;
    mix.strength_in = m.strength_in;
    mix.two_sided = m.two_sided;
    if ((a.tex || a.in || m.strength_in) && (m.is_emissive() || m.emission_from_graph()))
      scene_.warnings.add("emission not weighted by a textured or linked alpha (write the mix, its emission weighted)",
                          fmt::format("{}: {}", file_, a.path));
    mix.visible_to_camera = m.visible_to_camera;
    mix.casts_shadow = m.casts_shadow;
    mix.holdout = m.holdout;
    mix.holdout_weight = m.holdout_weight;
    mix.holdout_in = m.holdout_in;
    mix.interior = m.interior;
    mix.visible_lobes = m.visible_lobes;
    mix.normal_tex = m.normal_tex;
    mix.normal_strength = m.normal_strength;
    mix.bump_tex = m.bump_tex;
    mix.bump_strength = m.bump_strength;
    mix.bump_distance = m.bump_distance;
    mix.mix_a = std::make_shared<const Material>(std::move(clear));
    mix.mix_b = std::make_shared<const Material>(std::move(opaque));
    m = std::move(mix);
  }

  // The material's `nodes` table compiled for the inputs that link into it. A link without a
  // table, or a malformed table, fails naming the file, the material and the node.
  void load_graph_inputs(const json& m, const std::string& mpath, Material& mat, GraphInput* alpha_in) {
    using shading::SocketType;
    struct Want {
      const char* key;
      SocketType type;
      GraphInput* input;
    };
    const Want wants[] = {{"color", SocketType::Color, &mat.color_in},       {"roughness", SocketType::Float, &mat.roughness_in},
                          {"factor", SocketType::Float, &mat.factor_in},     {"ior", SocketType::Float, &mat.ior_in},
                          {"alpha", SocketType::Float, alpha_in},            {"normal", SocketType::Vector, &mat.normal_in},
                          {"emission", SocketType::Color, &mat.emission_in}, {"strength", SocketType::Float, &mat.strength_in},
                          {"holdout", SocketType::Float, &mat.holdout_in},
                          {"specular_tint", SocketType::Float, &mat.specular_tint_in}, {"sheen", SocketType::Float, &mat.sheen_in},
                          {"sheen_tint", SocketType::Float, &mat.sheen_tint_in},     {"clearcoat", SocketType::Float, &mat.clearcoat_in},
                          {"anisotropy", SocketType::Float, &mat.anisotropy_in},     {"rotation", SocketType::Float, &mat.rotation_in},
                          {"tangent", SocketType::Vector, &mat.tangent_in}};
    const json* nodes = find(m, "nodes");
    bool any = false;
    for (const Want& w : wants)
      if (const json* j = find(m, w.key); j && shading::is_link(*j)) any = true;
    if (const json* n = find(m, "normal"); n && !shading::is_link(*n))
      fail(sub(mpath, "normal"), "expected a link into 'nodes' (a Normal Map or Bump output)");
    if (!any) {
      if (nodes) require_object(*nodes, sub(mpath, "nodes"));
      return;
    }
    if (!nodes) fail(mpath, "an input links into the node graph but the material has no 'nodes'");
    try {
      shading::GraphCompiler g(mat.name, *nodes, [this](const std::string& file, const std::string& colorspace,
                                                         std::string* warning) {
        std::filesystem::path f = file;
        if (f.is_relative() && !base_dir_.empty()) f = std::filesystem::path(base_dir_) / f;
        TextureLoad loaded = load_texture(f.string(), colorspace);
        *warning = loaded.warning;
        return loaded.image;
      });
      std::vector<std::pair<int, GraphInput*>> roots;
      for (const Want& w : wants)
        if (const json* j = find(m, w.key); j && shading::is_link(*j)) {
          try {
            roots.push_back({g.link(*j, w.type), w.input});
          } catch (const shading::GraphError& e) {
            fail(sub(mpath, w.key), e.what());
          }
        }
      mat.graph = g.compile();
      for (auto& [root, input] : roots) {
        input->linked = true;
        input->source = g.source(root);
      }
      for (const std::string& w : g.warnings()) scene_.warnings.add("node graph approximated", fmt::format("{}: {}", file_, w));
    } catch (const shading::GraphError& e) {
      fail(sub(mpath, "nodes"), e.what());
    }
  }
  // ---- Media ----

  // "media": {"fog": {"sigma_a": c, "sigma_s": c, "g": g, "emission": c}}, colours (or greys) in
  // m^-1 (emission W sr^-1 m^-3), g in [-1, 1] clamped to Cycles' +-(1 - 1e-3).
  void load_media(const json& media, const std::string& path) {
    require_object(media, path);
    for (auto it = media.begin(); it != media.end(); ++it) {
      const std::string mpath = sub(path, it.key());
      const json& j = it.value();
      require_object(j, mpath);
      check_keys(j, mpath, {"sigma_a", "sigma_s", "g", "emission", "grid"});
      Medium m;
      m.name = it.key();
      if (const json* a = find(j, "sigma_a")) m.sigma_a = get_color(*a, sub(mpath, "sigma_a"));
      if (const json* b = find(j, "sigma_s")) m.sigma_s = get_color(*b, sub(mpath, "sigma_s"));
      if (const json* e = find(j, "emission")) m.emission = get_color(*e, sub(mpath, "emission"));
      if (const json* g = find(j, "g")) m.g = std::clamp(get_in_range(*g, sub(mpath, "g"), -1.0f, 1.0f),
                                                          -kMaxAnisotropy, kMaxAnisotropy);
      if (const json* g = find(j, "grid")) m.grid = load_grid_medium(*g, sub(mpath, "grid"));
      medium_index_[m.name] = static_cast<int>(scene_.media.size());
      scene_.media.push_back(std::move(m));
    }
  }
  // "grid": {"file": "smoke.vdb", "density_grid": "density", "color_grid": "color",
  // "temperature_grid": "temperature", "transform": {...}, and Principled Volume's "density",
  // "color", "absorption_color", "blackbody_intensity", "blackbody_tint", "temperature"}
  // (media/grid.h). The medium's sigma_a / sigma_s are its coefficients at density 1.
  std::shared_ptr<const GridMedium> load_grid_medium(const json& g, const std::string& path) {
    require_object(g, path);
    check_keys(g, path, {"file", "density_grid", "color_grid", "temperature_grid", "transform", "density", "color",
                         "absorption_color", "blackbody_intensity", "blackbody_tint", "temperature",
                         "smoke_color_grids", "flame_temperature"});
    need(g, "file", path);
    std::filesystem::path file = get_string(g["file"], sub(path, "file"));
    if (file.is_relative() && !base_dir_.empty()) file = std::filesystem::path(base_dir_) / file;
    auto grid = [&](const char* key) -> std::shared_ptr<const VoxelGrid> {
      const json* n = find(g, key);
      if (!n) return nullptr;
      const std::string name = get_string(*n, sub(path, key));
      if (name.empty()) return nullptr;
      const std::string cache_key = file.string() + '\n' + name;
      if (auto it = grids_.find(cache_key); it != grids_.end()) return it->second;
      try {
        std::shared_ptr<const VoxelGrid> v = read_vdb_grid(file.string(), name);
        grids_[cache_key] = v;
        return v;
      } catch (const VdbError& e) {
        fail(sub(path, key), e.what());
      }
    };
    auto density = grid("density_grid"), color = grid("color_grid"), temperature = grid("temperature_grid");
    if (const json* n = find(g, "smoke_color_grids")) {
      if (color) fail(path, "gives both 'color_grid' and 'smoke_color_grids'");
      color = smoke_color(*n, file.string(), sub(path, "smoke_color_grids"));
    }
    if (const json* f = find(g, "flame_temperature")) {
      if (!temperature) fail(sub(path, "flame_temperature"), "needs a 'temperature_grid' (the flame grid)");
      temperature = flame_temperature(*temperature, *f, sub(path, "flame_temperature"));
    }
    if (!density && !color && !temperature)
      fail(path, "names no grid: give 'density_grid', 'color_grid' or 'temperature_grid'");
    if (color && color->channels != 3 && color->channels != 1 && color->channels != 4) fail(sub(path, "color_grid"), "not a colour or float grid");
    if (density && density->channels != 1) fail(sub(path, "density_grid"), "is a vector grid, not a float grid");
    if (temperature && temperature->channels != 1) fail(sub(path, "temperature_grid"), "is a vector grid, not a float grid");
    GridMediumParams params;
    if (const json* v = find(g, "density")) params.density = get_nonnegative(*v, sub(path, "density"));
    if (const json* v = find(g, "color")) params.color = get_color(*v, sub(path, "color"));
    if (const json* v = find(g, "absorption_color")) params.absorption_color = get_color(*v, sub(path, "absorption_color"));
    if (const json* v = find(g, "blackbody_intensity"))
      params.blackbody_intensity = get_in_range(*v, sub(path, "blackbody_intensity"), 0.0f, 1.0f);
    if (const json* v = find(g, "blackbody_tint")) params.blackbody_tint = get_color(*v, sub(path, "blackbody_tint"));
    if (const json* v = find(g, "temperature")) params.temperature = get_nonnegative(*v, sub(path, "temperature"));
    Affine object_to_world;
    if (const json* t = find(g, "transform")) {
      const Transform x = load_transform(*t, sub(path, "transform"));
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j) object_to_world.m[i][j] = x.m[i][j];
    }
    try {
      return std::make_shared<const GridMedium>(density, color, temperature, object_to_world, params);
    } catch (const std::invalid_argument& e) {
      fail(path, fmt::format("{}: {}", file.string(), e.what()));
    }
  }

  // A baked smoke domain's colour as Cycles gets it from Blender (rna_fluid.c color_grid:
  // manta_smoke_get_rgba, the colour grids times the density, the density as alpha): the
  // file's grids [r, g, b, density] as one premultiplied RGBA grid over their common box
  // (media/grid.h, channels 4). Negative densities are 0 (the majorant's bound needs alpha >= 0).
  std::shared_ptr<const VoxelGrid> smoke_color(const json& names, const std::string& file, const std::string& path) {
    if (!names.is_array() || names.size() != 4)
      fail(path, "is not a list of four grid names (red, green, blue, density)");
    std::shared_ptr<const VoxelGrid> parts[4];
    for (int c = 0; c < 4; ++c) {
      const std::string name = get_string(names[c], sub(path, std::to_string(c)));
      try {
        parts[c] = read_vdb_grid(file, name);
      } catch (const VdbError& e) {
        fail(sub(path, std::to_string(c)), e.what());
      }
      if (parts[c]->channels != 1) fail(sub(path, std::to_string(c)), fmt::format("'{}' is a vector grid, not a float grid", name));
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j)
          if (std::abs(parts[c]->index_to_object.m[i][j] - parts[0]->index_to_object.m[i][j]) >
              1e-5f * (1 + std::abs(parts[0]->index_to_object.m[i][j])))
            fail(path, fmt::format("{}: grids '{}' and '{}' have different transforms (not resampled)", file,
                                   parts[0]->name, name));
    }
    auto rgba = std::make_shared<VoxelGrid>();
    rgba->name = parts[0]->name + "+" + parts[3]->name;
    rgba->channels = 4;
    rgba->index_to_object = parts[0]->index_to_object;
    std::array<int, 3> hi{};
    for (int a = 0; a < 3; ++a) {
      rgba->lo[a] = parts[0]->lo[a];
      hi[a] = parts[0]->lo[a] + parts[0]->size[a];
      for (const auto& p : parts) {
        if (p->voxels() == 0) continue;
        rgba->lo[a] = std::min(rgba->lo[a], p->lo[a]);
        hi[a] = std::max(hi[a], p->lo[a] + p->size[a]);
      }
      rgba->size[a] = std::max(0, hi[a] - rgba->lo[a]);
    }
    if (rgba->voxels() > kMaxGridVoxels) fail(path, fmt::format("{}: the colour grids span more than {} voxels", file, kMaxGridVoxels));
    rgba->data.resize(static_cast<size_t>(rgba->voxels()) * 4);
    size_t at = 0;
    for (int k = rgba->lo[2]; k < hi[2]; ++k)
      for (int j = rgba->lo[1]; j < hi[1]; ++j)
        for (int i = rgba->lo[0]; i < hi[0]; ++i) {
          const float d = std::max(parts[3]->at(i, j, k), 0.0f);
          for (int c = 0; c < 3; ++c) rgba->data[at++] = parts[c]->at(i, j, k) * d;
          rgba->data[at++] = d;
        }
    const float d = std::max(parts[3]->background[0], 0.0f);
    for (int c = 0; c < 3; ++c) rgba->background[c] = parts[c]->background[0] * d;
    rgba->background[3] = d;
    return rgba;
  }
  // A smoke domain's temperature as Cycles gets it from Blender (rna_fluid.c temperature_grid):
  // each voxel's flame f becomes ignition + f (max - ignition) where f > 0.01, else 0.
  std::shared_ptr<const VoxelGrid> flame_temperature(const VoxelGrid& flame, const json& j, const std::string& path) {
    if (!j.is_array() || j.size() != 2) fail(path, "is not [ignition, maximum temperature]");
    const float ignition = get_float(j[0], sub(path, "0")), max_temp = get_float(j[1], sub(path, "1"));
    auto t = std::make_shared<VoxelGrid>(flame);
    auto map = [&](float f) { return f > 0.01f ? ignition + f * (max_temp - ignition) : 0.0f; };
    for (float& v : t->data) v = map(v);
    t->background[0] = map(flame.background[0]);
    return t;
  }

  int medium_by_name(const json& j, const std::string& path) const {
    const std::string name = get_string(j, path);
    auto it = medium_index_.find(name);
    if (it == medium_index_.end()) {
      std::vector<std::string> names;
      for (const auto& [n, i] : medium_index_) names.push_back(n);
      fail(path, fmt::format("unknown medium '{}' (known: {})", name, names.empty() ? "none defined" : join(names)));
    }
    return it->second;
  }

  // A conductor's "fresnel": true (Schlick, the default), false (none: Blender's Glossy BSDF) or
  // "principled" (Cycles' Principled metal, interpolated with the dielectric Fresnel of "ior").
  ConductorFresnel load_conductor_fresnel(const json& f, const std::string& path) const {
    if (f.is_string()) {
      const std::string v = get_string(f, path);
      if (v == "principled") return ConductorFresnel::Principled;
      if (v == "schlick") return ConductorFresnel::Schlick;
      if (v == "none") return ConductorFresnel::None;
      fail(path, fmt::format("unknown conductor Fresnel '{}' (known: true, false, \"schlick\", \"none\", "
                             "\"principled\")", v));
    }
    return get_bool(f, path) ? ConductorFresnel::Schlick : ConductorFresnel::None;
  }

  // ---- Textured inputs ----

  static bool is_texture(const json& j) { return j.is_object() && j.contains("texture"); }
  // Blender's Interpolation menu; Smart is Cubic on Cycles' CPU kernel (device/cpu/image.h).
  static constexpr std::pair<const char*, TextureFilter> kFilters[] = {
      {"linear", TextureFilter::Linear}, {"closest", TextureFilter::Closest}, {"cubic", TextureFilter::Cubic},
      {"smart", TextureFilter::Cubic}};

  // A texture reference (docs/scene-format.md, "Textures"): the image, read once through the
  // texture store, and how the input reads it. `color` inputs default to the RGB channel,
  // scalar ones to the luminance. mean_value / mean_color receive the texture's average.
  TextureRef load_texture_ref(const json& j, const std::string& path, bool color,
                              std::initializer_list<std::string_view> extra_keys, float* mean_value = nullptr,
                              RGB* mean_color = nullptr, const char* default_colorspace = "") {
    require_object(j, path);
    std::vector<std::string_view> keys = {"texture", "colorspace", "channel", "wrap", "interpolation",
                                          "mapping", "scale", "square"};
    keys.insert(keys.end(), extra_keys.begin(), extra_keys.end());
    for (auto k = j.begin(); k != j.end(); ++k)
      if (std::find(keys.begin(), keys.end(), std::string_view(k.key())) == keys.end())
        scene_.warnings.add("unknown key", fmt::format("{}: {}", file_, sub(path, k.key())));
    std::filesystem::path file = get_string(need(j, "texture", path), sub(path, "texture"));
    if (file.empty()) fail(sub(path, "texture"), "empty file name");
    if (file.is_relative() && !base_dir_.empty()) file = std::filesystem::path(base_dir_) / file;
    std::string colorspace = default_colorspace;
    if (const json* c = find(j, "colorspace")) colorspace = get_string(*c, sub(path, "colorspace"));
    TextureRef t;
    TextureLoad loaded = load_texture(file.string(), colorspace);
    if (!loaded.warning.empty())
      scene_.warnings.add(loaded.image->missing ? "missing image texture (magenta)" : "image texture approximated",
                          fmt::format("{}: {}: {}", file_, path, loaded.warning));
    t.image = loaded.image;
    t.channel = color ? TextureChannel::RGB : TextureChannel::Luminance;
    if (const json* c = find(j, "channel")) {
      static const std::pair<const char*, TextureChannel> kChannels[] = {
          {"rgb", TextureChannel::RGB}, {"r", TextureChannel::R}, {"g", TextureChannel::G},
          {"b", TextureChannel::B},     {"a", TextureChannel::A}, {"luminance", TextureChannel::Luminance}};
      t.channel = pick(*c, sub(path, "channel"), kChannels, "rgb, r, g, b, a, luminance");
    }
    if (const json* w = find(j, "wrap")) {
      static const std::pair<const char*, TextureWrap> kWraps[] = {
          {"repeat", TextureWrap::Repeat}, {"extend", TextureWrap::Extend}, {"clip", TextureWrap::Clip}};
      t.wrap = pick(*w, sub(path, "wrap"), kWraps, "repeat, extend, clip");
    }
    if (const json* f = find(j, "interpolation")) {
      t.filter = pick(*f, sub(path, "interpolation"), kFilters, "linear, closest, cubic, smart");
    }
    if (const json* mp = find(j, "mapping")) {
      const std::string mpath = sub(path, "mapping");
      if (!mp->is_array() || mp->size() != 2)
        fail(mpath, fmt::format("expected [[a, b, c], [d, e, f]] (uv' = M uv + t), got {}", describe(*mp)));
      for (int r = 0; r < 2; ++r) {
        const json& row = (*mp)[r];
        if (!row.is_array() || row.size() != 3) fail(sub(mpath, r), fmt::format("expected 3 numbers, got {}", describe(row)));
        for (int c = 0; c < 3; ++c) t.mapping[r][c] = get_float(row[c], sub(sub(mpath, r), c));
      }
    }
    if (const json* s = find(j, "scale")) t.scale = get_float(*s, sub(path, "scale"));
    if (const json* q = find(j, "square")) t.square = get_bool(*q, sub(path, "square"));
    const RGBA& mean = t.image->mean;
    if (mean_color) *mean_color = RGB(std::clamp(mean.rgb.r * t.scale, 0.0f, 1.0f), std::clamp(mean.rgb.g * t.scale, 0.0f, 1.0f),
                                      std::clamp(mean.rgb.b * t.scale, 0.0f, 1.0f));
    if (mean_value) {
      float v = t.channel == TextureChannel::A ? mean.a : mean.rgb.luminance();
      if (t.channel == TextureChannel::R) v = mean.rgb.r;
      if (t.channel == TextureChannel::G) v = mean.rgb.g;
      if (t.channel == TextureChannel::B) v = mean.rgb.b;
      v *= t.scale;
      *mean_value = std::clamp(t.square ? v * v : v, 0.0f, 1.0f);
    }
    return t;
  }

  template <typename T, size_t N>
  T pick(const json& j, const std::string& path, const std::pair<const char*, T> (&choices)[N], const char* known) const {
    const std::string s = get_string(j, path);
    for (const auto& [name, value] : choices)
      if (s == name) return value;
    fail(path, fmt::format("unknown value '{}' (known: {})", s, known));
  }

  struct MixRef {
    size_t index;
    std::string a, b, path;
  };
  std::vector<MixRef> mix_refs_;

  void resolve_mix(const MixRef& r, std::vector<int>& state) {
    if (state[r.index] == 2) return;
    if (state[r.index] == 1) fail(r.path, "mix materials refer to each other in a cycle");
    state[r.index] = 1;
    std::shared_ptr<const Material> parts[2];
    const std::string* names[2] = {&r.a, &r.b};
    for (int k = 0; k < 2; ++k) {
      const uint32_t i = material_by_name(json(*names[k]), sub(r.path, k == 0 ? "a" : "b"));
      for (const MixRef& other : mix_refs_)
        if (other.index == i) resolve_mix(other, state);
      parts[k] = std::make_shared<const Material>(scene_.materials[i]);
    }
    Material& m = scene_.materials[r.index];
    m.mix_a = parts[0];
    m.mix_b = parts[1];
    m.roughness = std::max(parts[0]->roughness, parts[1]->roughness);  // for roughness-based classifiers
    // The colour a copy without components falls back to (Bsdf: diffuse of this colour).
    const float t = m.mix_add ? 1.0f : m.mix_factor;
    m.color = parts[0]->color * (m.mix_add ? 1.0f : 1.0f - t) + parts[1]->color * t;
    m.color = RGB(std::min(m.color.r, 1.0f), std::min(m.color.g, 1.0f), std::min(m.color.b, 1.0f));
    state[r.index] = 2;
  }

  uint32_t material_by_name(const json& j, const std::string& path) const {
    const std::string name = get_string(j, path);
    auto it = material_index_.find(name);
    if (it == material_index_.end()) fail(path, fmt::format("unknown material '{}' (known: {})", name, known_materials()));
    return it->second;
  }
  std::string known_materials() const {
    std::vector<std::string> names;
    for (const auto& [n, i] : material_index_) names.push_back(n);
    return names.empty() ? "none defined" : join(names);
  }

  // ---- Camera ----

  void load_camera(const json& c, const std::string& path) {
    require_object(c, path);
    check_keys(c, path, {"position", "look_at", "up", "matrix", "type", "fov", "ortho_scale", "sensor_fit", "width",
                         "height", "shift", "crop", "aperture_radius", "focus_distance", "pixel_filter", "motion",
                         "clip_start", "clip_end"});
    Camera cam;
    if (const json* m = find(c, "matrix")) {
      if (find(c, "position") || find(c, "look_at") || find(c, "up"))
        fail(path, "give either 'matrix' or 'position'/'look_at'/'up', not both");
      cam.camera_to_world = get_matrix(*m, sub(path, "matrix"));
    } else {
      if (!find(c, "position") || !find(c, "look_at"))
        fail(path, "needs 'position' and 'look_at' (with optional 'up'), or 'matrix'");
      const Vec3 eye = get_vec3(*find(c, "position"), sub(path, "position"));
      const Vec3 target = get_vec3(*find(c, "look_at"), sub(path, "look_at"));
      Vec3 up{0, 0, 1};
      if (const json* u = find(c, "up")) up = get_direction(*u, sub(path, "up"));
      const Vec3 d = target - eye;
      if (!(length(d) > 0)) fail(sub(path, "look_at"), "look_at equals position");
      const Vec3 f = normalize(d);
      const Vec3 x = cross(f, up);
      if (!(length(x) > 1e-6f)) fail(sub(path, "up"), "up is parallel to the viewing direction");
      const Vec3 right = normalize(x), cam_up = cross(right, f);
      // Blender's camera: +X right, +Y up, looking down -Z.
      const Vec3 cols[4] = {right, cam_up, -f, eye};
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 4; ++k) cam.camera_to_world.m[r][k] = cols[k][r];
    }
    if (const json* f = find(c, "fov")) {
      cam.fov_degrees = get_float(*f, sub(path, "fov"));
      if (!(cam.fov_degrees > 0 && cam.fov_degrees < 180))
        fail(sub(path, "fov"), fmt::format("must be between 0 and 180 degrees (got {})", cam.fov_degrees));
    }
    if (const json* s = find(c, "sensor_fit")) {
      const std::string fit = get_string(*s, sub(path, "sensor_fit"));
      if (fit == "auto") cam.sensor_fit = SensorFit::Auto;
      else if (fit == "horizontal") cam.sensor_fit = SensorFit::Horizontal;
      else if (fit == "vertical") cam.sensor_fit = SensorFit::Vertical;
      else fail(sub(path, "sensor_fit"), fmt::format("unknown sensor fit '{}' (known: auto, horizontal, vertical)", fit));
    }
    if (const json* w = find(c, "width")) cam.width = static_cast<int>(get_int(*w, sub(path, "width"), 1, 65536));
    if (const json* h = find(c, "height")) cam.height = static_cast<int>(get_int(*h, sub(path, "height"), 1, 65536));
    if (const json* a = find(c, "aperture_radius")) cam.aperture_radius = get_nonnegative(*a, sub(path, "aperture_radius"));
    if (const json* d = find(c, "focus_distance")) cam.focus_distance = get_positive(*d, sub(path, "focus_distance"));
    if (const json* t = find(c, "type")) {
      const std::string type = get_string(*t, sub(path, "type"));
      if (type == "perspective") cam.projection = Projection::Perspective;
      else if (type == "orthographic") cam.projection = Projection::Orthographic;
      else fail(sub(path, "type"), fmt::format("unknown camera type '{}' (known: perspective, orthographic)", type));
    }
    if (const json* o = find(c, "ortho_scale")) cam.ortho_scale = get_positive(*o, sub(path, "ortho_scale"));
    // Blender's Clip Start / End, as Cycles clips camera rays (Camera::clip_start).
    if (const json* n = find(c, "clip_start")) cam.clip_start = get_nonnegative(*n, sub(path, "clip_start"));
    if (const json* f = find(c, "clip_end")) {
      cam.clip_end = get_positive(*f, sub(path, "clip_end"));
      if (!(cam.clip_end > cam.clip_start))
        fail(sub(path, "clip_end"), fmt::format("must be beyond clip_start ({} <= {})", cam.clip_end, cam.clip_start));
    }
    if (const json* s = find(c, "shift")) cam.shift = get_vec2(*s, sub(path, "shift"));
    if (const json* w = find(c, "crop")) {
      const std::string wpath = sub(path, "crop");
      if (!w->is_array() || w->size() != 4) fail(wpath, "must be [x, y, width, height] in pixels");
      cam.crop_x = static_cast<int>(get_int((*w)[0], sub(wpath, 0), 0, cam.width - 1));
      cam.crop_y = static_cast<int>(get_int((*w)[1], sub(wpath, 1), 0, cam.height - 1));
      cam.crop_width = static_cast<int>(get_int((*w)[2], sub(wpath, 2), 1, cam.width - cam.crop_x));
      cam.crop_height = static_cast<int>(get_int((*w)[3], sub(wpath, 3), 1, cam.height - cam.crop_y));
    }
    if (const json* f = find(c, "pixel_filter")) cam.filter = load_pixel_filter(*f, sub(path, "pixel_filter"));
    if (const json* m = find(c, "motion")) {  // camera-to-world over the shutter (motion blur)
      const std::string mpath = sub(path, "motion");
      require_array(*m, mpath);
      if (m->size() < 2)
        fail(mpath, fmt::format("{} matrix(es); camera motion needs at least 2 (shutter open and close)", m->size()));
      std::vector<Transform> steps;
      for (size_t i = 0; i < m->size(); ++i) steps.push_back(get_matrix((*m)[i], sub(mpath, i)));
      cam.motion = TransformMotion(steps);
      if (cam.motion.still()) cam.motion = TransformMotion();
    }
    if (const std::string bad = cam.check(); !bad.empty()) fail(path, bad);
    scene_.camera = cam;
  }

  // Film > Pixel Filter: {"type": "box" | "gaussian" | "blackman-harris", "width": px}; the
  // width defaults to Blender's 1.5 (1 for box).
  PixelFilter load_pixel_filter(const json& f, const std::string& path) {
    require_object(f, path);
    check_keys(f, path, {"type", "width"});
    PixelFilterType type = PixelFilterType::Box;
    if (const json* t = find(f, "type")) {
      try {
        type = PixelFilter::parse_type(get_string(*t, sub(path, "type")));
      } catch (const std::invalid_argument& e) {
        fail(sub(path, "type"), e.what());
      }
    }
    float width = type == PixelFilterType::Box ? 1.0f : 1.5f;
    if (const json* w = find(f, "width")) width = get_in_range(*w, sub(path, "width"), 1e-3f, 64.0f);
    return PixelFilter(type, width);
  }

  // ---- Transforms ----

  Transform load_transform(const json& t, const std::string& path) {
    require_object(t, path);
    check_keys(t, path, {"translate", "rotate", "scale", "matrix"});
    if (const json* m = find(t, "matrix")) {
      if (find(t, "translate") || find(t, "rotate") || find(t, "scale"))
        fail(path, "give either 'matrix' or 'translate'/'rotate'/'scale', not both");
      return get_matrix(*m, sub(path, "matrix"));
    }
    // Blender's order: scale, then rotate (each rotation in list order), then translate.
    Transform result;
    if (const json* s = find(t, "scale")) {
      const std::string spath = sub(path, "scale");
      const Vec3 sv = s->is_number() ? Vec3(get_float(*s, spath)) : get_vec3(*s, spath);
      if (sv.x == 0 || sv.y == 0 || sv.z == 0) fail(spath, "scale must not be zero");
      result = Transform::scale(sv);
    }
    if (const json* r = find(t, "rotate")) {
      const std::string rpath = sub(path, "rotate");
      auto one = [&](const json& j, const std::string& p) {
        if (!j.is_array() || j.size() != 4)
          fail(p, fmt::format("expected a rotation [degrees, axis_x, axis_y, axis_z], got {}", describe(j)));
        const float deg = get_float(j[0], sub(p, 0));
        const Vec3 axis{get_float(j[1], sub(p, 1)), get_float(j[2], sub(p, 2)), get_float(j[3], sub(p, 3))};
        if (!(length(axis) > 0)) fail(p, "the rotation axis must be a non-zero vector");
        return Transform::rotate(deg, axis);
      };
      if (r->is_array() && !r->empty() && (*r)[0].is_array()) {
        for (size_t i = 0; i < r->size(); ++i) result = one((*r)[i], sub(rpath, i)) * result;
      } else {
        result = one(*r, rpath) * result;
      }
    }
    if (const json* tr = find(t, "translate")) result = Transform::translate(get_vec3(*tr, sub(path, "translate"))) * result;
    return result;
  }

  // ---- Objects ----

  // Analytic shapes are the one place where a few bytes of JSON ask for gigabytes: their
  // triangles are counted before tessellation, and a scene that would not fit in memory
  // fails here with the numbers instead of being killed by the kernel halfway through.
  void reserve_triangles(double triangles, const std::string& path, const std::string& name) {
    shape_triangles_ += triangles;
    const double need = shape_triangles_ * kBytesPerTriangle;
    if (budget_bytes_ < 0) budget_bytes_ = memory_budget_bytes();
    if (budget_bytes_ > 0 && need > budget_bytes_)
      fail(path, fmt::format("'{}' brings the scene's shapes to {:.0f} triangles, about {:.2f} GB, more than the {:.2f} GB "
                             "available (lower the segments; GRADPHOTON_MEMORY_LIMIT_MB sets the limit)",
                             name, shape_triangles_, need / 1e9, budget_bytes_ / 1e9));
  }

  void load_object(const json& o, const std::string& path) {
    require_object(o, path);
    const std::string type = get_string(need(o, "type", path), sub(path, "type"));
    std::string name = path;
    if (const json* n = find(o, "name")) name = get_string(*n, sub(path, "name"));
    const std::initializer_list<std::string_view> common = {"type", "name", "material", "transform", "motion",
                                                             "random_id"};
    auto keys = [&](std::initializer_list<std::string_view> extra) {
      std::vector<std::string_view> all(common);
      all.insert(all.end(), extra);
      for (auto it = o.begin(); it != o.end(); ++it)
        if (std::find(all.begin(), all.end(), std::string_view(it.key())) == all.end())
          scene_.warnings.add("unknown key", fmt::format("{}: {}", file_, sub(path, it.key())));
    };
    auto material = [&]() { return material_by_name(need(o, "material", path), sub(path, "material")); };
    auto center = [&]() {
      const json* c = find(o, "center");
      return c ? get_vec3(*c, sub(path, "center")) : Vec3(0.0f);
    };
    auto segments = [&](const char* key, int def) {
      const json* s = find(o, key);
      return s ? static_cast<int>(get_int(*s, sub(path, key), 3, 4096)) : def;
    };

    Mesh mesh;
    if (type == "sphere") {
      keys({"center", "radius", "segments"});
      const Vec3 c = center();
      const float r = get_positive(need(o, "radius", path), sub(path, "radius"));
      const int n = segments("segments", 48);
      reserve_triangles(2.0 * n * (std::max(2, n / 2) - 1), path, name);
      mesh = make_sphere(c, r, n, material());
    } else if (type == "quad") {
      keys({"center", "u", "v", "corners"});
      if (const json* corners = find(o, "corners")) {
        if (find(o, "center") || find(o, "u") || find(o, "v"))
          fail(path, "give either 'corners' or 'center'/'u'/'v', not both");
        const std::string cpath = sub(path, "corners");
        if (!corners->is_array() || corners->size() != 4)
          fail(cpath, fmt::format("expected 4 corners [[x,y,z], ...], got {}", describe(*corners)));
        Vec3 p[4];
        for (size_t i = 0; i < 4; ++i) p[i] = get_vec3((*corners)[i], sub(cpath, i));
        if (!(length(cross(p[1] - p[0], p[2] - p[0])) > 0) || !(length(cross(p[2] - p[0], p[3] - p[0])) > 0))
          fail(cpath, "the corners are degenerate (zero area)");
        mesh = make_quad_corners(p[0], p[1], p[2], p[3], material());
      } else {
        const Vec3 c = center();
        const Vec3 u = get_vec3(need(o, "u", path), sub(path, "u"));
        const Vec3 v = get_vec3(need(o, "v", path), sub(path, "v"));
        if (!(length(cross(u, v)) > 0)) fail(path, "'u' and 'v' must be non-zero and not parallel");
        mesh = make_quad(c, u, v, material());
      }
    } else if (type == "box") {
      keys({"min", "max"});
      const Vec3 lo = get_vec3(need(o, "min", path), sub(path, "min"));
      const Vec3 hi = get_vec3(need(o, "max", path), sub(path, "max"));
      if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z))
        fail(path, fmt::format("'min' must be below 'max' on every axis (size {} x {} x {})", hi.x - lo.x, hi.y - lo.y,
                               hi.z - lo.z));
      mesh = make_box(lo, hi, material());
    } else if (type == "torus") {
      keys({"center", "major_radius", "minor_radius", "segments_major", "segments_minor"});
      const Vec3 c = center();
      const float major = get_positive(need(o, "major_radius", path), sub(path, "major_radius"));
      const float minor = get_positive(need(o, "minor_radius", path), sub(path, "minor_radius"));
      if (!(minor < major)) fail(sub(path, "minor_radius"), fmt::format("must be below major_radius ({} >= {})", minor, major));
      const int n_major = segments("segments_major", 48), n_minor = segments("segments_minor", 24);
      reserve_triangles(2.0 * n_major * n_minor, path, name);
      mesh = make_torus(c, major, minor, n_major, n_minor, material());
    } else if (type == "disk") {
      keys({"center", "radius", "segments"});
      const Vec3 c = center();
      const float r = get_positive(need(o, "radius", path), sub(path, "radius"));
      const int n = segments("segments", 48);
      reserve_triangles(n, path, name);
      mesh = make_disk(c, r, n, material());
    } else if (type == "mesh") {
      keys({"positions", "indices", "normals", "uvs", "materials", "material_indices", "motion_positions", "colors",
            "attributes"});
      mesh = load_inline_mesh(o, path, name);
    } else if (type == "obj") {
      keys({"file"});
      mesh = load_obj(o, path, name);
    } else {
      fail(sub(path, "type"), fmt::format("unknown object type '{}' (known: mesh, obj, sphere, quad, box, torus, disk)", type));
    }
    mesh.name = name;
    if (const json* r = find(o, "random_id")) {  // Object Info's Random id (Mesh::random_id)
      if (!r->is_number_unsigned() || r->get<uint64_t>() > 0xFFFFFFFFull)
        fail(sub(path, "random_id"), "must be an integer in [0, 4294967295]");
      mesh.random_id = r->get<uint32_t>();
    }
    const json* motion = find(o, "motion");
    const json* deform = type == "mesh" ? find(o, "motion_positions") : nullptr;
    if (motion || deform) {
      load_motion(o, path, name, motion, deform, mesh);
    } else if (const json* t = find(o, "transform")) {
      const std::string tpath = sub(path, "transform");
      apply_transform(mesh, load_transform(*t, tpath));
      for (size_t v = 0; v < mesh.positions.size(); ++v)
        if (!is_finite(mesh.positions[v])) fail(tpath, fmt::format("transformed vertex {} of '{}' is not finite", v, name));
    }
    scene_.meshes.push_back(std::move(mesh));
  }

  // Motion blur (docs/scene-format.md "Motion blur"): "motion", S >= 2 transforms at evenly
  // spaced shutter times (instead of "transform"), and for inline meshes "motion_positions",
  // S' >= 2 object-space vertex arrays ([3N floats] or [[x, y, z], ...] each). `mesh` is still in
  // object space; it is placed at the frame: "transform", or the motion's mid-shutter transform.
  void load_motion(const json& o, const std::string& path, const std::string& name, const json* motion,
                   const json* deform, Mesh& mesh) {
    std::vector<Transform> steps;
    Transform frame;
    if (motion) {
      const std::string mpath = sub(path, "motion");
      if (find(o, "transform")) fail(path, fmt::format("object '{}' has both 'transform' and 'motion': give one", name));
      require_array(*motion, mpath);
      if (motion->size() < 2)
        fail(mpath, fmt::format("object '{}': {} transform(s); motion needs at least 2 (shutter open and close)", name,
                                motion->size()));
      for (size_t i = 0; i < motion->size(); ++i) steps.push_back(load_transform((*motion)[i], sub(mpath, i)));
      frame = TransformMotion(steps).at(0.5f);
    } else if (const json* t = find(o, "transform")) {
      frame = load_transform(*t, sub(path, "transform"));
    }
    std::vector<std::vector<Vec3>> vertices;
    if (deform) {
      const std::string dpath = sub(path, "motion_positions");
      require_array(*deform, dpath);
      if (deform->size() < 2)
        fail(dpath, fmt::format("object '{}': {} step(s); deformation needs at least 2 (shutter open and close)", name,
                                deform->size()));
      const size_t nv = mesh.positions.size();
      for (size_t s = 0; s < deform->size(); ++s) {
        const std::string spath = sub(dpath, s);
        const json& step = (*deform)[s];
        require_array(step, spath);
        std::vector<Vec3> v;
        if (!step.empty() && step[0].is_array()) {  // [[x, y, z], ...]
          for (size_t i = 0; i < step.size(); ++i) v.push_back(get_vec3(step[i], sub(spath, i)));
        } else {  // [3N floats]
          if (step.size() % 3 != 0) fail(spath, fmt::format("{} numbers are not 3 per vertex", step.size()));
          for (size_t i = 0; i + 2 < step.size(); i += 3)
            v.emplace_back(get_float(step[i], sub(spath, i)), get_float(step[i + 1], sub(spath, i + 1)),
                           get_float(step[i + 2], sub(spath, i + 2)));
        }
        if (v.size() != nv)
          fail(spath, fmt::format("object '{}': step {} has {} vertices but 'positions' has {}", name, s, v.size(), nv));
        vertices.push_back(std::move(v));
      }
    }
    try {
      set_mesh_motion(mesh, frame, steps, std::move(vertices));
    } catch (const std::invalid_argument& e) {
      fail(path, fmt::format("object '{}': {}", name, e.what()));
    }
  }

  Mesh load_inline_mesh(const json& o, const std::string& path, const std::string& name) {
    Mesh mesh;
    const std::string ppath = sub(path, "positions"), ipath = sub(path, "indices");
    const json& pos = need(o, "positions", path);
    require_array(pos, ppath);
    for (size_t i = 0; i < pos.size(); ++i) mesh.positions.push_back(get_vec3(pos[i], sub(ppath, i)));
    const json& idx = need(o, "indices", path);
    require_array(idx, ipath);
    for (size_t t = 0; t < idx.size(); ++t) {
      const std::string tpath = sub(ipath, t);
      if (!idx[t].is_array() || idx[t].size() != 3)
        fail(tpath, fmt::format("expected a triangle [i, j, k], got {}", describe(idx[t])));
      for (size_t k = 0; k < 3; ++k) {
        const uint32_t v = static_cast<uint32_t>(get_int(idx[t][k], sub(tpath, k), 0, std::numeric_limits<uint32_t>::max()));
        if (v >= mesh.positions.size())
          fail(tpath, fmt::format("triangle {} of '{}' uses vertex {} but the mesh has {} vertices", t, name, v,
                                  mesh.positions.size()));
        mesh.indices.push_back(v);
      }
    }
    if (const json* n = find(o, "normals")) {
      const std::string npath = sub(path, "normals");
      require_array(*n, npath);
      if (n->size() != mesh.positions.size())
        fail(npath, fmt::format("{} normals for {} positions (one per vertex)", n->size(), mesh.positions.size()));
      for (size_t i = 0; i < n->size(); ++i) mesh.normals.push_back(get_direction((*n)[i], sub(npath, i)));
    }
    if (const json* uv = find(o, "uvs")) {
      const std::string upath = sub(path, "uvs");
      require_array(*uv, upath);
      if (uv->size() != mesh.positions.size())
        fail(upath, fmt::format("{} uvs for {} positions (one per vertex)", uv->size(), mesh.positions.size()));
      for (size_t i = 0; i < uv->size(); ++i) mesh.uvs.push_back(get_vec2((*uv)[i], sub(upath, i)));
    }
    load_mesh_attributes(o, path, mesh);
    const size_t tris = mesh.triangle_count();
    const json* single = find(o, "material");
    const json* list = find(o, "materials");
    if (single && list) fail(path, "give either 'material' or 'materials' with 'material_indices', not both");
    if (single) {
      mesh.material_ids.assign(tris, material_by_name(*single, sub(path, "material")));
    } else if (list) {
      const std::string lpath = sub(path, "materials"), mipath = sub(path, "material_indices");
      require_array(*list, lpath);
      if (list->empty()) fail(lpath, "needs at least one material name");
      std::vector<uint32_t> ids;
      for (size_t i = 0; i < list->size(); ++i) ids.push_back(material_by_name((*list)[i], sub(lpath, i)));
      const json& mi = need(o, "material_indices", path);
      require_array(mi, mipath);
      if (mi.size() != tris) fail(mipath, fmt::format("{} entries for {} triangles (one per triangle)", mi.size(), tris));
      for (size_t t = 0; t < tris; ++t)
        mesh.material_ids.push_back(ids[get_int(mi[t], sub(mipath, t), 0, static_cast<int64_t>(ids.size()) - 1)]);
    } else {
      fail(path, "needs 'material' (or 'materials' with 'material_indices')");
    }
    return mesh;
  }

  // One attribute's values: each element a number or an array of 1-4 numbers, all alike.
  shading::MeshAttribute load_attribute_values(const json& v, const std::string& vpath, std::string name,
                                               shading::AttributeDomain domain, size_t elements) {
    static const char* kDomain[] = {"point", "corner", "face"};
    require_array(v, vpath);
    if (v.size() != elements)
      fail(vpath, fmt::format("{} values for {} elements (one per {})", v.size(), elements,
                              kDomain[static_cast<int>(domain)]));
    shading::MeshAttribute a;
    a.name = std::move(name);
    a.domain = domain;
    a.components = v.empty() || v[0].is_number() ? 1 : static_cast<uint8_t>(std::min<size_t>(v[0].size(), 255));
    if (a.components < 1 || a.components > 4)
      fail(sub(vpath, 0), fmt::format("expected a number or an array of 1 to 4 numbers, got {}", describe(v[0])));
    a.values.reserve(elements * a.components);
    for (size_t i = 0; i < v.size(); ++i) {
      const std::string ep = sub(vpath, i);
      if (a.components == 1 && v[i].is_number()) {
        a.values.push_back(get_float(v[i], ep));
        continue;
      }
      if (!v[i].is_array() || v[i].size() != a.components)
        fail(ep, fmt::format("expected {} numbers as the first element, got {}", a.components, describe(v[i])));
      for (size_t k = 0; k < a.components; ++k) a.values.push_back(get_float(v[i][k], sub(ep, k)));
    }
    return a;
  }

  // "colors": the render colour attribute, per vertex ([r, g, b] or [r, g, b, a]), named "Color";
  // "attributes": {name: {"domain": "point" | "corner" | "face", "values": [...]}} (docs/scene-format.md).
  void load_mesh_attributes(const json& o, const std::string& path, Mesh& mesh) {
    const json* colors = find(o, "colors");
    const json* attrs = find(o, "attributes");
    if (!colors && !attrs) return;
    auto out = std::make_shared<shading::MeshAttributes>();
    if (colors) {
      const std::string cpath = sub(path, "colors");
      shading::MeshAttribute a =
          load_attribute_values(*colors, cpath, "Color", shading::AttributeDomain::Point, mesh.positions.size());
      if (a.components < 3) fail(cpath, "colours are [r, g, b] or [r, g, b, a]");
      out->default_color = 0;
      out->list.push_back(std::move(a));
    }
    if (attrs) {
      const std::string apath = sub(path, "attributes");
      require_object(*attrs, apath);
      for (auto it = attrs->begin(); it != attrs->end(); ++it) {
        const std::string ap = sub(apath, it.key());
        require_object(*it, ap);
        check_keys(*it, ap, {"domain", "values"});
        shading::AttributeDomain domain = shading::AttributeDomain::Point;
        if (const json* d = find(*it, "domain")) {
          const std::string ds = get_string(*d, sub(ap, "domain"));
          if (ds == "corner") domain = shading::AttributeDomain::Corner;
          else if (ds == "face") domain = shading::AttributeDomain::Face;
          else if (ds != "point") fail(sub(ap, "domain"), fmt::format("unknown domain '{}' (known: point, corner, face)", ds));
        }
        const size_t tris = mesh.indices.size() / 3;
        const size_t n = domain == shading::AttributeDomain::Point    ? mesh.positions.size()
                         : domain == shading::AttributeDomain::Corner ? 3 * tris
                                                                       : tris;
        if (out->find(it.key())) fail(ap, fmt::format("attribute '{}' given twice ('colors' is named 'Color')", it.key()));
        out->list.push_back(load_attribute_values(need(*it, "values", ap), sub(ap, "values"), it.key(), domain, n));
      }
    }
    mesh.attributes = std::move(out);
  }

  Mesh load_obj(const json& o, const std::string& path, const std::string& name) {
    const std::string fpath = sub(path, "file");
    const std::string rel = get_string(need(o, "file", path), fpath);
    std::filesystem::path file(rel);
    if (file.is_relative() && !base_dir_.empty()) file = std::filesystem::path(base_dir_) / file;
    std::error_code ec;
    if (std::filesystem::exists(file, ec) && !std::filesystem::is_regular_file(file, ec))
      fail(fpath, fmt::format("OBJ file '{}' is not a regular file", file.string()));
    ObjMaterials materials;
    materials.by_name = [this](const std::string& n) -> std::optional<uint32_t> {
      auto it = material_index_.find(n);
      return it == material_index_.end() ? std::nullopt : std::optional<uint32_t>(it->second);
    };
    if (const json* m = find(o, "material")) materials.fallback = material_by_name(*m, sub(path, "material"));
    materials.known = known_materials();
    return read_obj_mesh(*this, file, path, fpath, name, materials, scene_.warnings);
  }

  // ---- Lights ----

  // A line emission spectrum: a preset name ("sodium", "mercury") or {"lines": [[nm, weight],
  // ...]} / {"preset": name}, with an optional "fwhm" (nm, default 1).
  void load_spectrum(const json& j, const std::string& path, std::vector<SpectralLine>& lines, float& fwhm) {
    fwhm = 1.0f;
    std::string preset;
    if (j.is_string()) {
      preset = get_string(j, path);
    } else {
      require_object(j, path);
      check_keys(j, path, {"preset", "lines", "fwhm"});
      if (find(j, "preset") && find(j, "lines")) fail(path, "give either 'preset' or 'lines', not both");
      if (const json* p = find(j, "preset")) preset = get_string(*p, sub(path, "preset"));
      if (const json* f = find(j, "fwhm")) fwhm = get_in_range(*f, sub(path, "fwhm"), 0.1f, 100.0f);
      if (const json* ls = find(j, "lines")) {
        if (!ls->is_array() || ls->empty() || ls->size() > static_cast<size_t>(kMaxSpectralLines))
          fail(sub(path, "lines"), fmt::format("must be a list of 1 to {} [nm, weight] pairs", kMaxSpectralLines));
        for (size_t i = 0; i < ls->size(); ++i) {
          const json& e = (*ls)[i];
          const std::string ep = fmt::format("{}[{}]", sub(path, "lines"), i);
          if (!e.is_array() || e.size() != 2) fail(ep, "must be [nm, weight]");
          const float nm = get_in_range(e[0], ep, kLambdaMin, kLambdaMax);
          lines.push_back({nm, get_positive(e[1], ep)});
        }
      } else if (preset.empty()) {
        fail(path, "needs 'preset' or 'lines'");
      }
    }
    if (!preset.empty()) {
      const auto p = spectral_line_preset(preset);
      if (!p) fail(path, fmt::format("unknown spectrum '{}' (known: sodium, mercury)", preset));
      lines = *p;
    }
  }

  // "intensity"/"irradiance" as a colour, or a scalar `power_key` times "color" scaled by
  // `power_scale`; with "spectrum", the scalar times the lines' unit-luminance colour.
  RGB light_value(const json& l, const std::string& path, const char* direct_key, const char* power_key, float power_scale,
                  Light& light) {
    if (const json* sp = find(l, "spectrum")) {
      if (find(l, "color") || find(l, direct_key))
        fail(path, fmt::format("'spectrum' goes with '{}' (a scalar), not with 'color' or '{}'", power_key, direct_key));
      load_spectrum(*sp, sub(path, "spectrum"), light.lines, light.line_fwhm);
      return spectral_lines_rgb(light.lines, light.line_fwhm) *
             (get_nonnegative(need(l, power_key, path), sub(path, power_key)) * power_scale);
    }
    return light_value(l, path, direct_key, power_key, power_scale);
  }
  RGB light_value(const json& l, const std::string& path, const char* direct_key, const char* power_key, float power_scale) {
    const json* direct = find(l, direct_key);
    const json* power = find(l, power_key);
    if (direct && power) fail(path, fmt::format("give either '{}' or '{}' (with 'color'), not both", direct_key, power_key));
    if (!direct && !power) fail(path, fmt::format("needs '{}' or '{}' (with optional 'color')", direct_key, power_key));
    if (direct) {
      if (find(l, "color")) fail(sub(path, "color"), fmt::format("'color' goes with '{}'; '{}' is already a colour", power_key, direct_key));
      return get_color(*direct, sub(path, direct_key));
    }
    RGB color(1.0f);
    if (const json* c = find(l, "color")) color = get_color(*c, sub(path, "color"));
    return color * (get_nonnegative(*power, sub(path, power_key)) * power_scale);
  }

  // Cycles' Diffuse / Glossy / Transmission visibility switches of a material or light
  // ("visible_to_diffuse" etc., true when absent) as kRay* bits.
  uint8_t load_visible_lobes(const json& o, const std::string& path) {
    uint8_t lobes = 0;
    for (const auto& [key, bit] : {std::pair{"visible_to_diffuse", kRayDiffuse}, std::pair{"visible_to_glossy", kRayGlossy},
                                   std::pair{"visible_to_transmission", kRayTransmission}}) {
      const json* v = find(o, key);
      if (!v || get_bool(*v, sub(path, key))) lobes |= bit;
    }
    return lobes;
  }

  void load_light(const json& l, const std::string& path) {
    require_object(l, path);
    const std::string type = get_string(need(l, "type", path), sub(path, "type"));
    Light light;
    light.name = path;
    if (const json* n = find(l, "name")) light.name = get_string(*n, sub(path, "name"));
    if (type == "point") {
      check_keys(l, path, {"type", "name", "position", "intensity", "power", "color", "spectrum", "radius",
                           "visible_to_diffuse", "visible_to_glossy", "visible_to_transmission", "motion"});
      light.type = LightType::Point;
      light.position = lamp_position(l, path);
      light.emit = light_value(l, path, "intensity", "power", kInv4Pi, light);
    } else if (type == "spot") {
      check_keys(l, path, {"type", "name", "position", "direction", "look_at", "spot_size", "spot_blend", "intensity",
                           "power", "color", "spectrum", "radius", "visible_to_diffuse", "visible_to_glossy",
                           "visible_to_transmission", "motion"});
      light.type = LightType::Spot;
      light.position = lamp_position(l, path);
      const json* d = find(l, "direction");
      const json* at = find(l, "look_at");
      if (d && at) fail(path, "give either 'direction' or 'look_at', not both");
      if (d) {
        light.direction = get_direction(*d, sub(path, "direction"));
      } else if (at) {
        const Vec3 to = get_vec3(*at, sub(path, "look_at")) - light.position;
        if (!(length(to) > 0)) fail(sub(path, "look_at"), "look_at equals position");
        light.direction = normalize(to);
      } else if (!find(l, "motion")) {
        fail(path, "needs 'direction' or 'look_at'");
      }
      float size = 45.0f, blend = 0.15f;  // Blender's defaults
      if (const json* s = find(l, "spot_size")) {
        size = get_float(*s, sub(path, "spot_size"));
        if (!(size > 0 && size <= 180)) fail(sub(path, "spot_size"), fmt::format("must be in (0, 180] degrees (got {})", size));
      }
      if (const json* b = find(l, "spot_blend")) blend = get_in_range(*b, sub(path, "spot_blend"), 0.0f, 1.0f);
      light.spot_cos_half = std::cos(0.5f * size * kPi / 180.0f);
      light.spot_smooth = (1.0f - light.spot_cos_half) * blend;
      light.emit = light_value(l, path, "intensity", "power", kInv4Pi, light);
    } else if (type == "sun") {
      check_keys(l, path, {"type", "name", "direction", "irradiance", "strength", "color", "spectrum", "angle",
                           "visible_to_diffuse", "visible_to_glossy", "visible_to_transmission", "motion"});
      light.type = LightType::Directional;
      if (const json* d = find(l, "direction")) light.direction = get_direction(*d, sub(path, "direction"));
      else if (!find(l, "motion")) need(l, "direction", path);
      if (const json* a = find(l, "angle"))  // full angle in degrees, as Blender's sun
        light.sun_tan_half = std::tan(0.5f * get_in_range(*a, sub(path, "angle"), 0.0f, 179.0f) * kPi / 180.0f);
      light.emit = light_value(l, path, "irradiance", "strength", 1.0f, light);
    } else {
      fail(sub(path, "type"), fmt::format("unknown light type '{}' (known: point, spot, sun)", type));
    }
    if (const json* r = find(l, "radius")) light.radius = get_nonnegative(*r, sub(path, "radius"));
    light.visible_lobes = load_visible_lobes(l, path);
    if (const json* m = find(l, "motion")) load_lamp_motion(*m, sub(path, "motion"), light);
    scene_.lights.push_back(std::move(light));
  }

  // A lamp's position: required, except under "motion" (the lamp's own space, origin by default).
  Vec3 lamp_position(const json& l, const std::string& path) {
    if (const json* p = find(l, "position")) return get_vec3(*p, sub(path, "position"));
    if (find(l, "motion")) return Vec3(0.0f);
    return get_vec3(need(l, "position", path), sub(path, "position"));
  }

  // A moving lamp (docs/scene-format.md "Motion blur"): S >= 2 transforms over the shutter, as
  // objects' "motion", placing the lamp's position and direction (its own space; by default
  // the origin and -Z, a Blender lamp's) at each time. The frame's are the mid-shutter ones.
  void load_lamp_motion(const json& m, const std::string& mpath, Light& light) {
    require_array(m, mpath);
    if (m.size() < 2)
      fail(mpath, fmt::format("light '{}': {} transform(s); motion needs at least 2 (shutter open and close)", light.name,
                              m.size()));
    std::vector<Transform> steps;
    for (size_t i = 0; i < m.size(); ++i) {
      steps.push_back(load_transform(m[i], sub(mpath, i)));
      if (const std::string bad = check_object_matrix(steps.back()); !bad.empty())
        fail(sub(mpath, i), fmt::format("light '{}': {}", light.name, bad));
    }
    auto motion = std::make_shared<TransformMotion>(steps);
    light.local_position = light.position;
    light.local_direction = light.direction;
    const Transform frame = motion->at(0.5f);
    light.position = frame.point(light.local_position);
    light.direction = normalize(frame.vector(light.local_direction));
    if (!motion->still()) light.lamp_motion = std::move(motion);  // steps all equal: a still lamp
  }

  // Keys of one background (docs/scene-format.md, "Environment"), by type.
  static constexpr const char* kMapKeys[] = {"image", "colorspace", "rotation", "transform", "interpolation", "projection",
                                             "sampling_resolution"};
  static constexpr const char* kSkyKeys[] = {"sky_type", "sun_disc", "sun_size", "sun_intensity", "sun_elevation",
                                             "sun_rotation", "altitude", "air_density", "dust_density", "ozone_density",
                                             "sun_direction", "turbidity"};
  static std::vector<std::string_view> background_keys() {
    std::vector<std::string_view> k{"type", "color", "strength", "backgrounds", "nodes", "surface"};
    for (const char* m : kMapKeys) k.push_back(m);
    for (const char* m : kSkyKeys) k.push_back(m);
    return k;
  }

  void load_environment(const json& e, const std::string& path) {
    require_object(e, path);
    std::vector<std::string_view> keys = background_keys();
    for (const char* k : {"camera", "visible_to_camera", "visible_to_diffuse", "visible_to_glossy", "visible_to_transmission"})
      keys.push_back(k);
    check_keys(e, path, keys);
    Light env;
    env.type = LightType::Environment;
    env.name = "environment";
    load_background(e, path, env.emit, env.map);
    // Light Path > Is Camera Ray: what camera rays see instead (a nested background).
    if (const json* c = find(e, "camera")) {
      const std::string cpath = sub(path, "camera");
      require_object(*c, cpath);
      check_keys(*c, cpath, background_keys());
      env.camera_override = true;
      load_background(*c, cpath, env.camera_emit, env.camera_map);
    }
    if (env.emit.is_black() && !env.map && !(env.camera_override && (env.camera_map || !env.camera_emit.is_black())))
      return;
    // World > Settings > Ray Visibility (Cycles' camera / diffuse / glossy / transmission).
    if (const json* v = find(e, "visible_to_camera")) env.visible_to_camera = get_bool(*v, sub(path, "visible_to_camera"));
    env.visible_lobes = load_visible_lobes(e, path);
    scene_.lights.push_back(std::move(env));
  }

  // One background (docs/scene-format.md, "Environment"): a constant colour x strength, an
  // image map (lights/environment_map.h) or a sky (lights/sky.h) scaled by them, or a sum of
  // backgrounds (lights/background.h). emit receives the constant, or the mean radiance of a
  // background that varies with direction (then in map).
  void load_background(const json& e, const std::string& path, RGB& emit, std::shared_ptr<const BackgroundTerm>& map) {
    std::string type = "color";
    if (const json* t = find(e, "type")) type = get_string(*t, sub(path, "type"));
    if (type != "color" && type != "map" && type != "sky" && type != "sum" && type != "graph")
      fail(sub(path, "type"), fmt::format("unknown environment type '{}' (known: color, map, sky, sum, graph)", type));
    auto only = [&](const char* key, const char* owner) {
      if (find(e, key)) fail(sub(path, key), fmt::format("only an environment of \"type\": \"{}\" takes it", owner));
    };
    if (type != "map")
      for (const char* k : kMapKeys) {
        const std::string_view key = k;
        if ((key == "transform" && type == "sky") || (key == "sampling_resolution" && type == "graph")) continue;
        only(k, "map");
      }
    if (type != "graph")
      for (const char* k : {"nodes", "surface"}) only(k, "graph");
    if (type != "sky")
      for (const char* k : kSkyKeys) only(k, "sky");
    if (type != "sum") only("backgrounds", "sum");
    if (type == "sum") {
      for (const char* k : {"color", "strength"})
        if (find(e, k)) fail(sub(path, k), "a sum takes its terms' colours and strengths (put them in \"backgrounds\")");
      load_background_sum(e, path, emit, map);
      return;
    }
    if (type == "graph") {
      for (const char* k : {"color", "strength"})
        if (find(e, k)) fail(sub(path, k), "a graph takes its colours and strengths from its \"surface\"");
      load_world_graph(e, path, emit, map);
      return;
    }
    RGB color(1.0f);
    float strength = 1.0f;
    if (const json* c = find(e, "color")) color = get_color(*c, sub(path, "color"));
    if (const json* s = find(e, "strength")) strength = get_nonnegative(*s, sub(path, "strength"));
    emit = color * strength;
    map = nullptr;
    if (type == "color") return;
    if (type == "sky") {
      load_sky(e, path, emit, map);
      return;
    }
    EnvironmentMapOptions o;
    o.scale = emit;
    std::filesystem::path file = get_string(need(e, "image", path), sub(path, "image"));
    if (file.empty()) fail(sub(path, "image"), "empty file name");
    if (file.is_relative() && !base_dir_.empty()) file = std::filesystem::path(base_dir_) / file;
    std::string colorspace;
    if (const json* c = find(e, "colorspace")) colorspace = get_string(*c, sub(path, "colorspace"));
    TextureLoad loaded = load_texture(file.string(), colorspace);
    if (!loaded.warning.empty())  // a missing HDRI renders magenta, as Cycles, with this one warning
      scene_.warnings.add(loaded.image->missing ? "missing image texture (magenta)" : "image texture approximated",
                          fmt::format("{}: {}: {}", file_, path, loaded.warning));
    if (const json* f = find(e, "interpolation")) o.filter = pick(*f, sub(path, "interpolation"), kFilters, "linear, closest, cubic, smart");
    if (const json* p = find(e, "projection")) {
      static const std::pair<const char*, EnvProjection> kProjections[] = {
          {"equirectangular", EnvProjection::Equirectangular}, {"mirror_ball", EnvProjection::MirrorBall}};
      o.projection = pick(*p, sub(path, "projection"), kProjections, "equirectangular, mirror_ball");
    }
    const json* rot = find(e, "rotation");
    const json* tr = find(e, "transform");
    if (rot && tr) fail(path, "give either 'rotation' or 'transform', not both");
    if (rot) {
      // Blender's Mapping rotation (Euler XYZ, degrees): the texture vector is Rz Ry Rx d.
      const Vec3 deg = get_vec3(*rot, sub(path, "rotation"));
      const Transform r = Transform::rotate(deg.z, Vec3(0, 0, 1)) * Transform::rotate(deg.y, Vec3(0, 1, 0)) *
                          Transform::rotate(deg.x, Vec3(1, 0, 0));
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) o.to_map[i][j] = r.m[i][j];
    }
    if (tr) read_matrix3(*tr, sub(path, "transform"), o.to_map);
    if (const json* r = find(e, "sampling_resolution")) {
      const std::string rpath = sub(path, "sampling_resolution");
      if (r->is_string()) {
        if (get_string(*r, rpath) != "auto") fail(rpath, "expected \"auto\" or a number of columns (Manual)");
      } else {  // Cycles' Manual map resolution: N x N/2 cells
        const int n = static_cast<int>(get_int(*r, rpath, 4, 32768));
        o.sampling_width = n;
        o.sampling_height = std::max(1, n / 2);
      }
    }
    try {
      map = std::make_shared<const EnvironmentMap>(loaded.image, o);
    } catch (const std::invalid_argument& ex) {
      fail(tr ? sub(path, "transform") : path, ex.what());
    }
    emit = map->integral() * kInv4Pi;
  }

  // World direction -> texture vector, row-major 3x3 (or 4x4: its linear part).
  void read_matrix3(const json& tr, const std::string& tpath, float out[3][3]) {
    if (!tr.is_array() || (tr.size() != 3 && tr.size() != 4))
      fail(tpath, fmt::format("expected a 3x3 or 4x4 matrix (rows), got {}", describe(tr)));
    const size_t n = tr.size();
    for (size_t i = 0; i < n; ++i) {
      const json& row = tr[i];
      if (!row.is_array() || row.size() != n) fail(sub(tpath, i), fmt::format("expected {} numbers, got {}", n, describe(row)));
      for (size_t j = 0; j < n; ++j) {
        const float v = get_float(row[j], sub(sub(tpath, i), j));
        if (i < 3 && j < 3) out[i][j] = v;
      }
    }
  }

  // The World's node graph (lights/world_graph.h): `surface` a tree of closures
  // ({"type": "background", "color", "strength"}, {"type": "mix", "factor", "a", "b"},
  // {"type": "add", "a", "b"}) whose inputs are constants or links into `nodes`.
  void load_world_graph(const json& e, const std::string& path, RGB& emit, std::shared_ptr<const BackgroundTerm>& map) {
    const json& nodes = need(e, "nodes", path);
    const std::string npath = sub(path, "nodes");
    require_object(nodes, npath);
    int widest = 0;  // Auto sampling resolution: the widest image the graph reads (Cycles: its Environment Textures')
    std::string images;  // which images (while alive, one address per file and colour space)
    std::vector<WorldClosure> closures;
    std::shared_ptr<const shading::ShaderProgram> program;
    try {
      shading::GraphCompiler g("World", nodes, [&](const std::string& file, const std::string& colorspace,
                                                   std::string* warning) {
        std::filesystem::path f = file;
        if (f.is_relative() && !base_dir_.empty()) f = std::filesystem::path(base_dir_) / f;
        TextureLoad loaded = load_texture(f.string(), colorspace);
        *warning = loaded.warning;
        if (loaded.image && !loaded.image->missing) widest = std::max(widest, loaded.image->width);
        images += fmt::format("{} {}\n", file, static_cast<const void*>(loaded.image.get()));  // the bake's key
        return loaded.image;
      });
      // (closure index, input: 0 color, 1 strength, 2 factor, compiled root): filled after compiling.
      struct Root {
        size_t closure;
        int input, root;
      };
      std::vector<Root> roots;
      auto input = [&](const json& c, const std::string& cpath, const char* key, int which, shading::SocketType type,
                       bool& linked) -> const json* {
        const json* v = find(c, key);
        if (v && shading::is_link(*v)) {
          try {
            roots.push_back({closures.size(), which, g.link(*v, type)});  // this closure is pushed next
          } catch (const shading::GraphError& ex) {
            fail(sub(cpath, key), ex.what());
          }
          linked = true;
          return nullptr;
        }
        return v;
      };
      // Children first (WorldGraph's order), depth bounded: an untrusted file cannot recurse forever.
      std::function<int(const json&, const std::string&, int)> closure = [&](const json& c, const std::string& cpath,
                                                                            int depth) -> int {
        if (depth > 64) fail(cpath, "closures nested deeper than 64");
        if (closures.size() >= 1024) fail(cpath, "more than 1024 closures");
        require_object(c, cpath);
        const std::string type = get_string(need(c, "type", cpath), sub(cpath, "type"));
        WorldClosure w;
        if (type == "background") {
          check_keys(c, cpath, {"type", "color", "strength"});
          w.kind = WorldClosure::Kind::Background;
          if (const json* v = input(c, cpath, "color", 0, shading::SocketType::Color, w.color_linked))
            w.color_constant = get_color(*v, sub(cpath, "color"));
          if (const json* v = input(c, cpath, "strength", 1, shading::SocketType::Float, w.strength_linked))
            w.strength_constant = get_float(*v, sub(cpath, "strength"));
        } else if (type == "mix" || type == "add") {
          check_keys(c, cpath, type == "mix" ? std::vector<std::string_view>{"type", "factor", "a", "b"}
                                             : std::vector<std::string_view>{"type", "a", "b"});
          w.kind = type == "mix" ? WorldClosure::Kind::Mix : WorldClosure::Kind::Add;
          w.a = closure(need(c, "a", cpath), sub(cpath, "a"), depth + 1);
          w.b = closure(need(c, "b", cpath), sub(cpath, "b"), depth + 1);
          if (type == "mix")  // after the children: this closure is the next one pushed
            if (const json* v = input(c, cpath, "factor", 2, shading::SocketType::Float, w.fac_linked))
              w.fac_constant = get_float(*v, sub(cpath, "factor"));
        } else {
          fail(sub(cpath, "type"), fmt::format("unknown World closure '{}' (known: background, mix, add)", type));
        }
        closures.push_back(w);
        return static_cast<int>(closures.size()) - 1;
      };
      closure(need(e, "surface", path), sub(path, "surface"), 0);
      program = g.compile();
      for (const Root& r : roots) {
        WorldClosure& w = closures[r.closure];
        (r.input == 0 ? w.color : r.input == 1 ? w.strength : w.fac) = g.source(r.root);
      }
      for (const std::string& w : g.warnings()) scene_.warnings.add("node graph approximated", fmt::format("{}: {}", file_, w));
    } catch (const shading::GraphError& ex) {
      fail(npath, ex.what());
    }
    int width = widest;
    if (const json* r = find(e, "sampling_resolution")) {
      const std::string rpath = sub(path, "sampling_resolution");
      if (r->is_string()) {
        if (get_string(*r, rpath) != "auto") fail(rpath, "expected \"auto\" or a number of columns (Manual)");
      } else {
        width = static_cast<int>(get_int(*r, rpath, 4, 8192));  // each cell is 1 to 4 graph evaluations: bounded
      }
    }
    const shading::ShadingCamera camera = make_shading_camera(scene_.camera);
    // A rotation or strength edit reuses the bake of the graph it was made from (world_graph.h).
    const WorldGraphFrame frame = world_graph_frame(e, images);
    try {
      map = std::make_shared<const WorldGraph>(program, std::move(closures), width, &camera,
                                               fmt::format("graph {:016x}", std::hash<std::string>()(e.dump())), &frame);
    } catch (const std::invalid_argument& ex) {
      fail(path, ex.what());
    }
    emit = map->integral() * kInv4Pi;
  }

  // A Sky Texture on the Background (lights/sky.h); angles in degrees as Blender shows them.
  void load_sky(const json& e, const std::string& path, RGB& emit, std::shared_ptr<const BackgroundTerm>& map) {
    // Each sky is precomputed (about a tenth of a second): a bound keeps an untrusted file from
    // asking for thousands of them.
    if (++skies_ > kMaxSkies) fail(path, fmt::format("at most {} skies in a scene", kMaxSkies));
    SkyOptions o;
    std::string model = "nishita";
    if (const json* t = find(e, "sky_type")) model = get_string(*t, sub(path, "sky_type"));
    if (model == "preetham") {
      o.model = SkyModel::Preetham;
    } else if (model == "hosek_wilkie") {
      // Its fitted tables are not available here (no Debian package ships them): Preetham,
      // with the same sun direction and turbidity, and one warning.
      o.model = SkyModel::Preetham;
      scene_.warnings.add("Hosek-Wilkie sky rendered as Preetham", fmt::format("{}: {}", file_, path));
    } else if (model != "nishita") {
      fail(sub(path, "sky_type"), fmt::format("unknown sky type '{}' (known: nishita, preetham, hosek_wilkie)", model));
    }
    auto degrees = [&](const char* key, float& out) {
      if (const json* v = find(e, key)) out = get_float(*v, sub(path, key)) * (kPi / 180.0f);
    };
    auto nonnegative = [&](const char* key, float& out) {
      if (const json* v = find(e, key)) out = get_nonnegative(*v, sub(path, key));
    };
    if (const json* v = find(e, "sun_disc")) o.sun_disc = get_bool(*v, sub(path, "sun_disc"));
    degrees("sun_size", o.sun_size);
    degrees("sun_elevation", o.sun_elevation);
    degrees("sun_rotation", o.sun_rotation);
    nonnegative("sun_intensity", o.sun_intensity);
    nonnegative("altitude", o.altitude);
    nonnegative("air_density", o.air_density);
    nonnegative("dust_density", o.dust_density);
    nonnegative("ozone_density", o.ozone_density);
    nonnegative("turbidity", o.turbidity);
    if (o.sun_size < 0) fail(sub(path, "sun_size"), "expected an angle >= 0");
    if (const json* v = find(e, "sun_direction")) o.sun_direction = get_vec3(*v, sub(path, "sun_direction"));
    o.scale = RGB(1.0f);  // the sky is shared (World edits reuse it), the Background's colour x strength on top
    try {
      std::shared_ptr<const BackgroundTerm> sky = shared_sky(o);
      // The Sky Texture's Vector through Texture Coordinate -> Mapping (a turned sun or sky).
      if (const json* tr = find(e, "transform")) {
        float m[3][3];
        read_matrix3(*tr, sub(path, "transform"), m);
        try {
          sky = std::make_shared<const TransformedBackground>(sky, m);
        } catch (const std::invalid_argument& ex) {
          fail(sub(path, "transform"), ex.what());
        }
      }
      map = std::make_shared<const ScaledBackground>(sky, emit);
    } catch (const std::invalid_argument& ex) {
      fail(path, ex.what());
    }
    emit = map->integral() * kInv4Pi;
  }

  // Cycles' Mix / Add Shader of Backgrounds: the terms' radiances add (a Mix's factor already in
  // each term's strength). A sum of constants stays a constant World, as Cycles renders it.
  void load_background_sum(const json& e, const std::string& path, RGB& emit, std::shared_ptr<const BackgroundTerm>& map) {
    const std::string bpath = sub(path, "backgrounds");
    const json& list = need(e, "backgrounds", path);
    require_array(list, bpath);
    if (list.empty()) fail(bpath, "expected at least one background");
    if (list.size() > 64) fail(bpath, fmt::format("at most 64 backgrounds, got {}", list.size()));
    emit = RGB(0.0f);
    std::vector<std::shared_ptr<const BackgroundTerm>> terms;
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string tpath = sub(bpath, i);
      require_object(list[i], tpath);
      check_keys(list[i], tpath, background_keys());
      RGB term_emit;
      std::shared_ptr<const BackgroundTerm> term;
      load_background(list[i], tpath, term_emit, term);
      if (term) {
        if (term->integral().average() > 0) terms.push_back(std::move(term));  // a black map adds nothing
      } else {
        emit += term_emit;
      }
    }
    map = nullptr;
    if (terms.empty()) return;  // constants only
    if (!emit.is_black()) terms.push_back(std::make_shared<const ConstantBackground>(emit));
    try {
      map = terms.size() == 1 ? terms[0] : std::make_shared<const BackgroundSum>(std::move(terms));
    } catch (const std::invalid_argument& ex) {
      fail(bpath, ex.what());
    }
    emit = map->integral() * kInv4Pi;
  }

  static constexpr int kMaxSkies = 16;
  int skies_ = 0;
  std::string base_dir_;
  std::map<std::string, std::shared_ptr<const VoxelGrid>> grids_;  // (file, grid) read once per scene
  Scene& scene_;
  std::map<std::string, uint32_t> material_index_;
  std::map<std::string, int> medium_index_;
  double shape_triangles_ = 0;
  double budget_bytes_ = -1;  // memory_budget_bytes(), read at the first shape
};

}  // namespace

Scene parse_scene_from_string(const std::string& json_text, const std::string& base_dir,
                              const std::string& name_for_messages) {
  const json root = parse_json(json_text, name_for_messages);
  Scene scene;
  scene.source = name_for_messages;
  Loader(name_for_messages, base_dir, scene).load(root);
  return scene;
}

Scene load_scene_from_string(const std::string& json_text, const std::string& base_dir,
                             const std::string& name_for_messages) {
  Scene scene = parse_scene_from_string(json_text, base_dir, name_for_messages);
  finalize_scene(scene);
  return scene;
}

void finalize_scene(Scene& scene) {
  try {
    scene.finalize();
  } catch (const SceneError&) {
    throw;
  } catch (const std::runtime_error& e) {
    // Scene::finalize's messages start with scene.source and name the mesh.
    throw SceneError(e.what());
  }
}

Scene load_scene(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw SceneError(fmt::format("{}: is a directory, not a scene file", path));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(fmt::format("{}: cannot open scene file ({})", path, std::strerror(errno)));
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw SceneError(fmt::format("{}: cannot read scene file", path));
  return load_scene_from_string(buffer.str(), std::filesystem::path(path).parent_path().string(), path);
}

}  // namespace gp
