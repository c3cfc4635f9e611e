// The method registry (integrators/methods.h): one declaration per parameter, its defaults the
// measured ones, one wording for every bad value, and the unused-parameter report.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

#include "integrators/methods.h"
#include "distributed/merge.h"
#include "render_for_tests.h"
#include "session/render_session.h"

namespace gp {
namespace {

std::string error_of(const std::string& method, const Scene& s, nlohmann::json params) {
  try {
    make_integrator(method, s, Params(std::move(params)));
  } catch (const ParamError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Methods, NamesComeFromTheRegistrations) {
  std::vector<std::string> names;
  for (const Method& m : methods()) names.push_back(m.name);
  EXPECT_EQ(integrator_names(), names);
  EXPECT_EQ(names, (std::vector<std::string>{"pt", "ppm", "sppm", "sppm-adaptive", "msppm", "gpt", "gpm", "gdmlt",
                                              "spt", "spt-hero", "sgpt"}));
}

// The defaults are measured (docs/gradient.md "Defaults (measured)", docs/photon-mapping.md):
// the registry carries exactly the constructors' former inline defaults.
TEST(Methods, DefaultsAreTheMeasuredOnes) {
  auto def = [](const std::string& method, const std::string& name) {
    const ParamDecl* d = find_method(method).find(name);
    return d ? d->default_value : nlohmann::json("(not declared)");
  };
  const std::vector<std::tuple<std::string, std::string, nlohmann::json>> expected = {
      {"pt", "max_depth", 32},         {"pt", "rr_depth", 3},           {"pt", "wavelengths", 4},
      {"pt", "clamp_direct", 0.0},     {"ppm", "alpha", 0.7},           {"ppm", "footprint", 2.0},
      {"ppm", "photons", 100000},      {"sppm", "alpha", 0.7},          {"sppm", "footprint", 2.0},
      {"sppm", "photons", 0},         {"sppm", "confidence", 0.5},     {"sppm", "hash", "exact"},
      {"sppm", "photon_sampler", "uniform"}, {"sppm-adaptive", "photon_sampler", "adaptive"}, {"sppm-adaptive", "photons", 100000},
      {"sppm", "chains", 64},          {"sppm", "wavelengths", 4},      {"sppm", "specular_threshold", 0.05},
      {"msppm", "alpha", 0.6},         {"msppm", "photons", 0},         {"msppm", "max_depth", 16},
      {"msppm", "path_samples", 0},    {"msppm", "path_samples_max", 64}, {"gpt", "recon", "l2"},
      {"gpt", "lambda", 0.2},          {"gpm", "photons", 0},           {"gpm", "alpha", 0.7},
      {"gpm", "footprint", 2.0},       {"gpm", "recon", "l1"},          {"gpm", "lambda", 0.2},
      {"gpm", "gradient_footprint", 1.0}, {"gpm", "gradient_photons", 1.0}, {"gpm", "manifold_iterations", 20}, {"gdmlt", "recon", "l1"},     {"gdmlt", "mutations", 1},
      {"gdmlt", "chains", 64},         {"gdmlt", "large_step", 0.3},    {"gdmlt", "sigma", 0.01},
      {"gdmlt", "primal_share", 0.05}, {"gdmlt", "bootstrap", 1},       {"gdmlt", "large_step_mis", true},
      {"gdmlt", "direct", "chain"},    {"spt", "wavelengths", 1},       {"spt-hero", "wavelengths", 4},
      {"sgpt", "lambda", 0.2},         {"sgpt", "bins", 15},            {"sgpt", "delta", 0.15},
      {"sgpt", "tau", 0.0},            {"sgpt", "wavelengths", 1}};
  for (const auto& [method, name, value] : expected) EXPECT_EQ(def(method, name), value) << method << " " << name;
  // One name, one meaning: sgpt's Poisson weight is lambda, like gpt's and gpm's; alpha is only
  // the photon radius reduction.
  EXPECT_EQ(find_method("sgpt").find("alpha"), nullptr);
  EXPECT_EQ(find_method("gdmlt").find("alpha"), nullptr);
}

// A name means one thing: wherever it is declared it has one type, label, description, and is
// shared or not (defaults, ranges, symbols and equations may be the method's own).
TEST(Methods, OneNameOneMeaning) {
  std::map<std::string, const ParamDecl*> first;
  for (const Method& m : methods()) {
    std::set<std::string> seen;
    for (const ParamDecl& d : m.params) {
      EXPECT_TRUE(seen.insert(d.name).second) << m.name << " declares " << d.name << " twice";
      EXPECT_FALSE(d.label.empty() || d.description.empty()) << m.name << " " << d.name;
      EXPECT_NO_THROW(d.checked(d.default_value, m.name)) << m.name << " " << d.name << ": default out of range";
      if (!d.zero_means.empty()) EXPECT_NO_THROW(d.checked(d.manual_value, m.name)) << m.name << " " << d.name;
      auto [it, inserted] = first.emplace(d.name, &d);
      if (inserted) continue;
      const ParamDecl& f = *it->second;
      EXPECT_EQ(d.type, f.type) << d.name;
      EXPECT_EQ(d.label, f.label) << d.name;
      EXPECT_EQ(d.description, f.description) << d.name;
      EXPECT_EQ(d.shared, f.shared) << d.name;
    }
  }
}

// Every declared parameter is read: built with all of them given at their defaults, a method
// leaves unread only those whose declaration says when they are read (read_when), and reads
// nothing it does not declare (Params::get throws std::logic_error for that).
TEST(Methods, EveryDeclaredParameterIsRead) {
  const Scene s = cornell_box(4, 4);
  for (const Method& m : methods()) {
    Params p;
    for (const ParamDecl& d : m.params) p.set(d.name, d.default_value);
    ASSERT_NO_THROW(make_integrator(m.name, s, p)) << m.name;
    for (const std::string& name : p.unused()) {
      const ParamDecl* d = m.find(name);
      ASSERT_NE(d, nullptr);
      EXPECT_FALSE(d->read_when.empty()) << m.name << " leaves " << name << " unread and does not say when it reads it";
    }
  }
}

TEST(Methods, OneWordingForEveryBadValue) {
  const Scene s = cornell_box(4, 4);
  EXPECT_EQ(error_of("gpm", s, {{"lambda", -1}}), "parameter 'lambda' of gpm must be > 0, got -1");
  EXPECT_EQ(error_of("sppm", s, {{"alpha", 1.0}}), "parameter 'alpha' of sppm must be in (0, 1), got 1.0");
  EXPECT_EQ(error_of("sppm", s, {{"alpha", "x"}}), "parameter 'alpha' of sppm must be a number, got \"x\"");
  EXPECT_EQ(error_of("sppm", s, {{"photons", 2.5}}), "parameter 'photons' of sppm must be an integer, got 2.5");
  EXPECT_EQ(error_of("msppm", s, {{"photons", -1}}), "parameter 'photons' of msppm must be >= 0, got -1");
  EXPECT_EQ(error_of("sppm", s, {{"hash", "fuzzy"}}),
            "parameter 'hash' of sppm must be one of exact, stochastic, got \"fuzzy\"");
  EXPECT_EQ(error_of("sgpt", s, {{"bins", 2}}), "parameter 'bins' of sgpt must be in [3, 256], got 2");
  EXPECT_EQ(error_of("gdmlt", s, {{"large_step_mis", 1}}),
            "parameter 'large_step_mis' of gdmlt must be true or false, got 1");
  EXPECT_EQ(error_of("pt", s, {{"max_depth", 0}}), "parameter 'max_depth' of pt must be >= 1, got 0");
  // An integral number is an integer (JSON from Python or a CLI "1e5").
  EXPECT_EQ(error_of("sppm", s, {{"photons", 1e3}}), "(accepted)");
  EXPECT_EQ(error_of("nope", s, nlohmann::json::object()).rfind("unknown method 'nope' (known: pt, ppm,", 0), 0u);
}

TEST(Methods, UnusedParameterReport) {
  const Scene s = cornell_box(4, 4);
  Params p(nlohmann::json{{"alhpa", 0.5}, {"chains", 8}, {"bins", 30}});
  make_integrator("sppm", s, p);
  EXPECT_EQ(unused_parameter_report("sppm", p),
            (std::vector<std::string>{"parameter 'alhpa' is not a parameter of sppm (did you mean 'alpha'?)",
                                      "parameter 'bins' is not a parameter of sppm",
                                      "parameter 'chains' of sppm is not read with these settings (read only with "
                                      "photon_sampler=adaptive)"}));
  // sgpt's Poisson weight was read as `alpha` while front ends sent `lambda`: now `alpha` is
  // reported and `lambda` reaches the reconstruction.
  Params sg(nlohmann::json{{"alpha", 0.7}});
  make_integrator("sgpt", s, sg);
  EXPECT_EQ(unused_parameter_report("sgpt", sg),
            std::vector<std::string>{"parameter 'alpha' is not a parameter of sgpt"});
}

TEST(Methods, SgptLambdaReachesTheReconstruction) {
  const Scene s = test_scene("prism", 8, 6);
  // Sum over pixels of |reconstruction - primal|: 0 as lambda -> inf (eq. 14 keeps the primal).
  auto distance = [&](double lambda) {
    const Film f = render("sgpt", s, 2, Params(nlohmann::json{{"lambda", lambda}, {"seed", 3}}));
    const auto& c = f.pass(pass::kCombined).data;
    const auto& p = f.pass(pass::kSpectralPrimal).data;
    double d = 0;
    for (size_t i = 0; i < c.size(); ++i) d += std::abs(c[i] - p[i]);
    return d;
  };
  const double low = distance(0.01), high = distance(100.0);
  EXPECT_GT(low, 0.0);
  EXPECT_GT(low, 10 * high) << low << " " << high;
}

}  // namespace
}  // namespace gp

namespace gp {
namespace {

// What a method declares of itself is what it does: the passes develop() writes (with and
// without a transparent film, on a dispersive scene too: pt turns spectral there), whether it
// estimates its error, and the merge rule's two facts as the integrators' own structure shows
// them (a gradient method writes gradients; a photon method writes a radius).
TEST(Methods, DeclarationIsWhatTheMethodRenders) {
  const Scene plain = test_scene("cornell-glass", 6, 4), dispersive = test_scene("prism", 6, 4);
  for (const Method& m : methods())
    for (const Scene* s : {&plain, &dispersive})
      for (bool transparent : {false, true}) {
        nlohmann::json p = {{"threads", 1}, {"seed", 3}};
        if (m.find("photons")) p["photons"] = 2000;
        if (transparent && !m.find("film_transparent")) continue;
        if (transparent) p["film_transparent"] = true;
        if (s == &dispersive && m.name == "sgpt") p["bins"] = 3;
        const Params given(p);
        auto integ = make_integrator(m.name, *s, given);
        integ->iterate(nullptr);
        Film film;
        integ->develop(film);
        std::vector<std::string> written;
        for (const auto& [name, pass] : film.passes()) written.push_back(name);
        std::vector<std::string> declared = find_method(integ->name()).passes_with(m.bind(given), s);
        std::sort(written.begin(), written.end());
        std::sort(declared.begin(), declared.end());
        const std::string what = m.name + " as " + integ->name() + (transparent ? ", transparent" : "") + " on " +
                                 s->source;
        EXPECT_EQ(written, declared) << what;
        EXPECT_EQ(integ->estimated_error() >= 0, find_method(integ->name()).error_estimate) << what;
        EXPECT_EQ(film.has_pass(pass::kGradientX), m.merge.reconstructs) << what;
        EXPECT_EQ(film.has_pass(pass::kRadius), m.merge.keeps_bias) << what;
      }
}

// Statistics keys are one style (lower-case words) and every declared one is reported by a run
// that uses what it measures.
TEST(Methods, DeclaredStatisticsAreReported) {
  const Scene s = test_scene("cornell-glass", 8, 6);
  for (const Method& m : methods()) {
    for (const StatDecl& d : m.stats)
      for (char c : d.key) EXPECT_FALSE(c == '_' && d.key != "V_c") << m.name << ": " << d.key;
    nlohmann::json p = {{"threads", 1}};
    if (m.find("photons")) p["photons"] = 5000;
    if (m.find("photon_sampler")) p["photon_sampler"] = "adaptive";
    auto integ = make_integrator(m.name, s, Params(p));
    for (int i = 0; i < 2; ++i) integ->iterate(nullptr);
    for (const StatDecl& d : m.stats) {
      if (d.key.find('*') != std::string::npos) continue;  // counted by reason: may be none
      EXPECT_TRUE(integ->stats().extra.count(d.key)) << m.name << " does not report '" << d.key << "'";
    }
  }
}

}  // namespace
}  // namespace gp

namespace gp {
namespace {

// A new method is its own class, one registration and its tests: this one (the first surface's
// albedo, one camera ray per pixel) is registered here, and every front end's way in then offers
// it: the registry, parameter binding and the unused report, the render session (the CLI's and
// Python's), the pass declaration, the merge rule.
class AlbedoMethod : public Integrator {
 public:
  AlbedoMethod(const Scene& s, const Params& p) : scene_(s), gain_(p.get<double>("gain")) {}
  std::string name() const override { return "test-albedo"; }
  void iterate(ProgressSink*) override { ++stats_.passes; }
  void develop(Film& film) const override {
    const int w = scene_.camera.film_width(), h = scene_.camera.film_height();
    film = Film(w, h);
    Pass& c = film.add_pass(pass::kCombined, 3);
    std::fill(c.data.begin(), c.data.end(), static_cast<float>(gain_));
  }

 private:
  const Scene& scene_;
  double gain_;
};

TEST(Methods, ANewMethodIsOneRegistration) {
  register_method({.name = "test-albedo", .label = "Test Albedo", .summary = "a constant image (a test)",
                   .tooltip = "a test method",
                   .params = {{.name = "gain", .type = ParamType::Float, .default_value = 0.5, .min = 0,
                               .label = "Gain", .description = "the image's value"}},
                   .make = [](const Scene& s, const Params& p) { return std::make_unique<AlbedoMethod>(s, p); },
                   .passes = {{pass::kCombined, ""}}});
  EXPECT_THROW(register_method({.name = "test-albedo"}), std::invalid_argument);
  EXPECT_EQ(integrator_names().back(), "test-albedo");
  auto scene = std::make_shared<Scene>(cornell_box(4, 3));
  RenderSession session(scene, "test-albedo", Params(nlohmann::json{{"gain", 0.25}, {"gian", 1}}));
  ASSERT_EQ(session.unused_report().size(), 1u);
  EXPECT_NE(session.unused_report()[0].find("did you mean 'gain'"), std::string::npos);
  session.run(StopRule{.passes = 2}, nullptr);
  const Film film = session.develop();
  EXPECT_FLOAT_EQ(film.rgb(pass::kCombined, 1, 1).r, 0.25f);
  EXPECT_TRUE(film.has_pass(pass::kAlbedo));  // the session's auxiliary passes come with it
  EXPECT_FALSE(merge_keeps_bias("test-albedo"));
  EXPECT_THROW(make_integrator("test-albedo", *scene, Params(nlohmann::json{{"gain", -1}})), ParamError);
  unregister_method("test-albedo");  // later tests (in this process) see the built-in methods
  EXPECT_EQ(integrator_names().back(), "sgpt");
}

}  // namespace
}  // namespace gp
