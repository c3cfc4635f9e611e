// A Mix / Add Shader's components are evaluated once per shading point, when the mix's BSDF is
// made (bsdf_params: BsdfParams::parts), RGB and spectral: eval, sample, pdf, closure_pdf and
// the classifiers then run no node graph (issue 30), and give exactly (bit for bit) what the
// components looked up per call gave.
#include <gtest/gtest.h>

#include <memory>

#include "materials/bsdf.h"
#include "materials/spectral_material.h"
#include "shading_test_util.h"

namespace gp {
namespace {

using shading::ShaderProgram;
using shading::ShadingContext;
using shading::SocketType;

// Noise (3D, its colour and factor) at the shading point's position: every run costs.
constexpr const char* kNoise =
    R"({"tc": {"type": "ShaderNodeTexCoord"},
        "n": {"type": "ShaderNodeTexNoise", "inputs": {"Vector": {"link": "tc", "output": "Object"},
                                                       "Scale": 3.0, "Detail": 2.0}}})";

GraphInput linked(const shading::test::Compiled& c) { return GraphInput{true, c.source}; }

// A diffuse whose colour, a GGX conductor whose roughness, and a dielectric whose tint the graph drives.
Material diffuse_textured() {
  Material m;
  m.type = MaterialType::Diffuse;
  const auto c = shading::test::compile_output(kNoise, "n", "Color");
  m.graph = c.program;
  m.color_in = linked(c);
  return m;
}
Material conductor_textured() {
  Material m;
  m.type = MaterialType::Conductor;
  m.color = RGB(0.9f, 0.6f, 0.3f);
  const auto c = shading::test::compile_output(kNoise, "n", "Fac", SocketType::Float);
  m.graph = c.program;
  m.roughness_in = linked(c);
  return m;
}
Material glass_textured() {
  Material m;
  m.type = MaterialType::Dielectric;
  m.roughness = 0.2f;
  m.cauchy_b = 0.01f;  // dispersive: the IOR varies with the wavelength
  const auto c = shading::test::compile_output(kNoise, "n", "Color");
  m.graph = c.program;
  m.color_in = linked(c);
  return m;
}
std::shared_ptr<const Material> mix_of(const Material& a, const Material& b, bool add, bool factor_from_graph) {
  auto m = std::make_shared<Material>();
  m->type = MaterialType::Mix;
  m->mix_a = std::make_shared<const Material>(a);
  m->mix_b = std::make_shared<const Material>(b);
  m->mix_add = add;
  m->mix_factor = 0.35f;
  if (factor_from_graph) {
    const auto c = shading::test::compile_output(kNoise, "n", "Fac", SocketType::Float);
    m->graph = c.program;
    m->factor_in = linked(c);
  }
  return m;
}
// mix(mix(diffuse, conductor) by the graph, add(glass, diffuse)): 5 graphs per point.
std::shared_ptr<const Material> nested_mix() {
  const auto inner = mix_of(diffuse_textured(), conductor_textured(), false, true);
  const auto added = mix_of(glass_textured(), diffuse_textured(), true, false);
  return mix_of(*inner, *added, false, false);
}
ShadingContext point() {
  ShadingContext c;
  c.P = Vec3(0.31f, -0.72f, 0.18f);
  c.uv = Vec2(0.4f, 0.6f);
  return c;
}

const Vec3 kWo = normalize(Vec3(0.3f, -0.2f, 0.9f));
const Vec3 kWis[] = {normalize(Vec3(-0.4f, 0.1f, 0.8f)), normalize(Vec3(0.5f, 0.5f, 0.3f)),
                     normalize(Vec3(-0.3f, -0.2f, -0.9f)), normalize(Vec3(-0.28f, 0.21f, 0.93f))};

// Everything a path asks of a BSDF, made into values.
std::vector<float> queries(const Bsdf& b) {
  std::vector<float> v;
  for (const Vec3& wi : kWis) {
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
      const RGB f = b.eval(kWo, wi, mode);
      v.insert(v.end(), {f.r, f.g, f.b});
    }
    const RGB fd = b.eval(kWo, wi, TransportMode::Radiance, kRayDiffuse);
    v.insert(v.end(), {fd.r, fd.g, fd.b, b.pdf(kWo, wi), b.pdf(kWo, wi, kRayGlossy), b.closure_pdf(kWo, wi)});
  }
  for (float uc : {0.05f, 0.3f, 0.55f, 0.8f, 0.97f})
    for (Vec2 u : {Vec2(0.2f, 0.7f), Vec2(0.9f, 0.1f)}) {
      const auto s = b.sample(kWo, uc, u);
      v.push_back(s ? 1.0f : 0.0f);
      if (s) v.insert(v.end(), {s->f.r, s->f.g, s->f.b, s->pdf, s->wi.x, s->wi.y, s->wi.z, float(s->delta)});
    }
  v.insert(v.end(), {float(b.is_delta()), float(b.is_black()), float(b.is_diffuse_for_photons())});
  return v;
}

TEST(BsdfMixCache, ComponentsRunTheirGraphsOnceWhenTheBsdfIsMade) {
  const auto m = nested_mix();
  const ShadingContext ctx = point();
  const uint64_t r0 = ShaderProgram::runs_on_this_thread();
  const Bsdf b(*m, ctx);
  const uint64_t r1 = ShaderProgram::runs_on_this_thread();
  EXPECT_EQ(r1 - r0, 5u);  // the inner mix's factor, diffuse, conductor, glass, diffuse
  const std::vector<float> v = queries(b);
  EXPECT_GT(v.size(), 50u);
  EXPECT_EQ(ShaderProgram::runs_on_this_thread(), r1) << "eval / sample / pdf re-ran a component's graph";

  // Spectral: the surface is made once (5 runs); its wavelengths and their queries run none.
  const SpectralSurface surface(*m, ctx, nullptr);
  const uint64_t r2 = ShaderProgram::runs_on_this_thread();
  EXPECT_EQ(r2 - r1, 5u);
  for (float lambda : {420.0f, 510.0f, 605.0f, 700.0f}) queries(Bsdf(surface.at(lambda), ctx));
  EXPECT_EQ(ShaderProgram::runs_on_this_thread(), r2) << "a wavelength re-ran a component's graph";
}

void check_against_lookups(const std::shared_ptr<const Material>& m) {
  const ShadingContext ctx = point();
  // Without parts, the components are looked up per call (parameters made by hand).
  auto uncached = [&](BsdfParams p) {
    p.parts = nullptr;
    return Bsdf(p, ctx);
  };
  const BsdfParams rgb = bsdf_params(*m, ctx);
  ASSERT_NE(rgb.parts, nullptr);
  const std::vector<float> cached_rgb = queries(Bsdf(rgb, ctx)), looked_up_rgb = queries(uncached(rgb));
  ASSERT_EQ(cached_rgb.size(), looked_up_rgb.size());
  for (size_t i = 0; i < cached_rgb.size(); ++i) EXPECT_EQ(cached_rgb[i], looked_up_rgb[i]) << "RGB value " << i;

  const SpectralSurface surface(*m, ctx, nullptr);
  for (float lambda : {420.0f, 510.0f, 605.0f, 700.0f}) {
    const BsdfParams p = surface.at(lambda);
    ASSERT_NE(p.parts, nullptr);
    ASSERT_TRUE(p.parts->spectral);
    const std::vector<float> cached = queries(Bsdf(p, ctx)), looked_up = queries(uncached(p));
    ASSERT_EQ(cached.size(), looked_up.size());
    for (size_t i = 0; i < cached.size(); ++i) EXPECT_EQ(cached[i], looked_up[i]) << lambda << " nm, value " << i;
  }
}

TEST(BsdfMixCache, CachedComponentsGiveExactlyWhatPerCallLookupsGave) {
  // One level (the reference looks its components up per call) and the nested mix.
  for (const auto& m : {mix_of(diffuse_textured(), conductor_textured(), false, true),
                        mix_of(glass_textured(), diffuse_textured(), true, false), nested_mix()})
    check_against_lookups(m);
}

}  // namespace
}  // namespace gp
