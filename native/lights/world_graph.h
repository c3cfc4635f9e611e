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
#pragma once

#include <memory>
#include <string>
#include <vector>

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

class WorldGraph final : public BackgroundTerm {
 public:
  // `closures` with the root last; `program` may be null (all constants). sampling_width 0:
  // Auto. `camera` (may be null) is copied: Texture Coordinate's Camera and Window.
  // Throws std::invalid_argument for a malformed closure list.
  WorldGraph(std::shared_ptr<const shading::ShaderProgram> program, std::vector<WorldClosure> closures,
             int sampling_width, const shading::ShadingCamera* camera, std::string identity);
  // As a light sample and photons see it (no path flags).
  RGB eval(const Vec3& dir) const override { return eval(dir, RayState()); }
  // As a ray of state `ray` that left the scene sees it (Light Path).
  RGB eval(const Vec3& dir, const RayState& ray) const override;
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override;
  float pdf(const Vec3& dir) const override;
  RGB integral() const override { return baked_.integral; }
  std::string identity() const override { return identity_; }
  int sampling_width() const { return baked_.grid.nu(); }
  int sampling_height() const { return baked_.grid.nv(); }

 private:
  RGB closure(int i, const Vec3* regs) const;
  void bake(int width);
  std::shared_ptr<const shading::ShaderProgram> program_;
  std::vector<WorldClosure> closures_;
  shading::ShadingCamera camera_;
  bool has_camera_ = false;
  std::string identity_;
  BakedDirections baked_;  // the sampling grid, as light samples see the World
};

}  // namespace gp
