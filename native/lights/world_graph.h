// The World's node graph as a light (docs/scene-format.md, "Environment", "type": "graph"): what
// the simpler backgrounds (a map, a sky, their sums) cannot say -- a Mix Shader's Fac linked to
// a texture or a gradient, Light Path outputs anywhere in the tree (Is Camera Ray through Math
// or Map Range, Is Glossy Ray), a Mapping with a location, Window coordinates -- evaluated per
// direction and per ray as Cycles' SVM evaluates the World shader (kernel/svm/closure.h:
// Background, Mix and Add closures; the Mix factor clamped to [0, 1]).
//
// The closures' inputs are the core's node evaluator (shading/graph.h) over the World's
// `nodes` table, with a direction-only shading context (P = the direction, Generated = Object =
// the direction, as Cycles' background ShaderData), plus ShaderNodeTexEnvironment and
// ShaderNodeTexSky (shading/nodes.cpp).
//
// Sampling, as Cycles' light manager does for a World (scene/light.cpp,
// device_update_background): the World is baked into an equirectangular map of W x W/2 cells
// (Manual resolution, else the largest Environment Texture's width, else 1024), evaluated as a
// light sample sees it (no path flags: Cycles' PATH_RAY_EMISSION, Light Path outputs 0), and
// sampled by a piecewise-constant distribution over luminance x sin(theta), floored at 1e-3 of
// the mean so that every direction the World lights has density. eval() is the graph itself,
// exact; only the density is the baked one.
//
// A Nishita Sky Texture with its sun disc in the graph (its Vector the direction, or through
// the rotation described below) gets its own sample: the grid is baked without the disc and the
// sun's cone is sampled uniformly, mixed with the grid in proportion to their power (one-sample
// MIS, as SkyTexture does for a World that is only a sky; the density is the mixture's, so BSDF
// rays and light samples meet it by MIS in every method).
//
// Edits in place (the rendered viewport, Persistent Data): a bake is shared by every graph with
// the same key (WorldGraphFrame). A graph whose radiance is strength x g(F d) -- one Mapping
// turning the direction (Texture Coordinate Generated/Object) in front of every texture that
// reads it, the root a Background of constant strength -- keys without F and the strength, so
// turning the HDRI or changing the strength reuses the grid: its frame turned by F0^T F1, its
// integral scaled by s1 / s0. A graph whose root is an Add or a Mix of constant factor is a
// weighted sum of terms -- each Background of constant strength (its colour; a constant colour
// is a uniform term), each Mix of linked factor and each Background of linked strength below
// those (the subtree) -- and is baked term by term (BakedTerms): its key without the factors,
// the strengths and the constant colours names the terms' bake, so a strength, factor or
// constant colour edit anywhere in that sum re-weights it (milliseconds) instead of baking the
// graph again; a fresh bake of such a graph goes the same way, so both sample alike bit for
// bit. Any other edit bakes again (the images stay loaded: the texture store shares them while
// the previous scene holds them).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/color.h"
#include "core/math.h"
#include "core/sampling.h"
#include "lights/background.h"
#include "shading/graph.h"

namespace gp {

// One closure of the World's surface: a Background (its Color x Strength), or a Mix (of
// children a and b by factor) or Add of two closures. Inputs are constants or program sources.
struct WorldClosure {
  enum class Kind { Background, Mix, Add } kind = Kind::Background;
  bool color_linked = false, strength_linked = false, fac_linked = false;
  shading::InputSource color, strength, fac;
  RGB color_constant{1.0f};
  float strength_constant = 1.0f, fac_constant = 0.5f;
  int a = -1, b = -1;  // children (Mix, Add), indices into the closure list
};

// What a World graph's bake depends on, read from its JSON (world_graph_frame): `key` names the
// bake (the graph, less the turning Mapping's rotation and the root's strength where those are
// separable); the radiance is strength x g(frame d) for the g that `key` names. `suns` are the
// Nishita sun discs the graph reads along frame d (their direction and angular diameter in the
// sky's own frame), sampled by their cones; `suns_complete` when every sun disc of the graph is
// among them (only then is the grid baked without the discs).
struct WorldGraphFrame {
  std::string key;
  float frame[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  float strength = 1.0f;
  struct Sun {
    Vec3 direction;
    float size = 0;
  };
  std::vector<Sun> suns;
  bool suns_complete = false;
  // The key of the terms' bake, less the weights (see above); empty when the root is not such
  // a sum.
  std::string terms_key;
};
// The frame of the World graph `env` ({"type": "graph", "nodes", "surface"}); `images`
// identifies the images its nodes read (their content is part of the key).
WorldGraphFrame world_graph_frame(const nlohmann::json& env, const std::string& images);

// A bake shared by the World graphs of one key, and the terms' bake shared by those of one
// terms_key (world_graph.cpp's caches).
struct WorldBake;
struct WorldTermsBake;

class WorldGraph final : public BackgroundTerm {
 public:
  // `closures` with the root last; `program` may be null (all constants). sampling_width 0:
  // Auto. `camera` (may be null) is copied: Texture Coordinate's Camera and Window. `frame`
  // (may be null: a bake of its own) shares the bake of an equal key (see above).
  // Throws std::invalid_argument for a malformed closure list.
  WorldGraph(std::shared_ptr<const shading::ShaderProgram> program, std::vector<WorldClosure> closures,
             int sampling_width, const shading::ShadingCamera* camera, std::string identity,
             const WorldGraphFrame* frame = nullptr);
  ~WorldGraph() override;
  // As a light sample and photons see it (no path flags).
  RGB eval(const Vec3& dir) const override { return eval(dir, RayState()); }
  // As a ray of state `ray` that left the scene sees it (Light Path).
  RGB eval(const Vec3& dir, const RayState& ray) const override;
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override;
  float pdf(const Vec3& dir) const override;
  RGB integral() const override;
  std::string identity() const override { return identity_; }
  int sampling_width() const;
  int sampling_height() const;
  // Whether this graph reuses a bake made for another (an edit in place), and the probability
  // that sample() draws from a sun's cone (0 without one).
  bool reused_bake() const { return reused_; }
  // Whether its sampling was re-weighted from the terms' bake made for another graph (a
  // strength, factor or constant colour edit inside a Mix / Add), and how many terms the graph
  // is baked as (1: the graph whole; 0: only constants).
  bool reused_terms() const { return reused_terms_; }
  int baked_terms() const { return static_cast<int>(terms_.size()); }
  float sun_probability() const;

 private:
  // A term of the sum the graph is baked as: closure `closure`'s value (`colour`: a Background's
  // colour alone, its strength in the weight), times `weight` (the factors and strengths above it).
  struct Term {
    int closure = -1;
    bool colour = false;
    float weight = 1.0f;
  };
  void split_terms();
  const Vec3* run(const Vec3& dir, const RayState& ray) const;
  RGB closure(int i, const Vec3* regs) const;
  std::shared_ptr<const WorldTermsBake> bake_terms(int width, const WorldGraphFrame& frame) const;
  // The sampling of this graph's weights from `terms` (kept in it when `keep`: a sum's).
  std::shared_ptr<const WorldBake> combine(std::shared_ptr<const WorldTermsBake> terms, bool keep) const;
  Vec3 to_bake(const Vec3& d) const;    // world direction -> the bake's world (q_ d)
  Vec3 from_bake(const Vec3& v) const;  // q_^T v
  std::shared_ptr<const shading::ShaderProgram> program_;
  std::vector<WorldClosure> closures_;
  shading::ShadingCamera camera_;
  bool has_camera_ = false;
  std::string identity_;
  std::shared_ptr<const WorldBake> baked_;  // the sampling grid and sun cones, as light samples see the World
  float q_[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // F_bake^T F_this: a rotation
  float scale_ = 1.0f;                                 // strength / the bake's strength
  bool reused_ = false, reused_terms_ = false;
  bool turned_ = false;  // q_ applies (the bake's frame is not this graph's)
  std::vector<Term> terms_;  // the graph whole when its root is not a sum of constant weights
  RGB constant_{0.0f};       // the sum's uniform part: its constant-colour Backgrounds
};

// While one lives on a thread, the World evaluated there is seen by a ray from `origin` (Cycles'
// sd->ray_P; LightSet::environment_radiance sets it for a path's ray). Texture Coordinate's
// Window of a camera ray through an orthographic camera reads it (shading/nodes.cpp): all such
// rays share the view's direction, so Cycles places the ray's origin in the frame instead.
class WorldRayOrigin {
 public:
  explicit WorldRayOrigin(const Vec3& origin);
  ~WorldRayOrigin();
  WorldRayOrigin(const WorldRayOrigin&) = delete;
  WorldRayOrigin& operator=(const WorldRayOrigin&) = delete;
  static const Vec3* get();  // null: none

 private:
  Vec3 origin_;
  const Vec3* previous_;
};

// Number of World bakes alive in the shared cache (tests: "baked once").
size_t world_bake_cache_size();

}  // namespace gp
