#include "lights/world_graph.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/parallel.h"
#include "lights/environment_map.h"

namespace gp {

WorldGraph::WorldGraph(std::shared_ptr<const shading::ShaderProgram> program, std::vector<WorldClosure> closures,
                       int sampling_width, const shading::ShadingCamera* camera, std::string identity)
    : program_(std::move(program)), closures_(std::move(closures)), identity_(std::move(identity)) {
  if (closures_.empty()) throw std::invalid_argument("a World graph without a closure");
  for (size_t i = 0; i < closures_.size(); ++i) {
    const WorldClosure& c = closures_[i];
    if (c.kind == WorldClosure::Kind::Background) continue;
    // Children come before their parent: the list is a tree built bottom-up, never a cycle.
    if (c.a < 0 || c.b < 0 || size_t(c.a) >= i || size_t(c.b) >= i)
      throw std::invalid_argument("a World graph's Mix or Add closure without its two inputs");
  }
  if ((closures_.back().fac_linked || closures_.back().color_linked || closures_.back().strength_linked) && !program_)
    throw std::invalid_argument("a World graph's closure reads a node but there is no node program");
  if (camera) {
    camera_ = *camera;
    has_camera_ = true;
  }
  bake(sampling_width > 0 ? sampling_width : 1024);  // Cycles' default map resolution
}

RGB WorldGraph::closure(int i, const Vec3* regs) const {
  const WorldClosure& c = closures_[size_t(i)];
  switch (c.kind) {
    case WorldClosure::Kind::Background: {
      const RGB color = c.color_linked ? RGB(regs[c.color.reg].x, regs[c.color.reg].y, regs[c.color.reg].z)
                                       : c.color_constant;
      const float s = c.strength_linked ? shading::as_float(regs[c.strength.reg], c.strength.conv) : c.strength_constant;
      return color * s;
    }
    case WorldClosure::Kind::Add: return closure(c.a, regs) + closure(c.b, regs);
    case WorldClosure::Kind::Mix: {
      // svm_node_mix_closure: the factor clamped to [0, 1] (saturatef).
      float f = c.fac_linked ? shading::as_float(regs[c.fac.reg], c.fac.conv) : c.fac_constant;
      f = std::isfinite(f) ? std::clamp(f, 0.0f, 1.0f) : 0.0f;
      RGB L(0.0f);
      if (f < 1.0f) L += closure(c.a, regs) * (1.0f - f);
      if (f > 0.0f) L += closure(c.b, regs) * f;
      return L;
    }
  }
  return RGB(0.0f);
}

RGB WorldGraph::eval(const Vec3& dir, const RayState& ray) const {
  thread_local std::vector<Vec3> regs;
  shading::ShadingContext ctx = shading::ShadingContext::direction(dir);
  ctx.ray = ray;
  ctx.camera = has_camera_ ? &camera_ : nullptr;
  const Vec3* r = nullptr;
  if (program_) {
    regs.resize(program_->num_registers());
    program_->run(ctx, regs.data());
    r = regs.data();
  }
  RGB L = closure(int(closures_.size()) - 1, r);
  // A negative strength or colour (allowed by Blender) lights nothing here; NaN never leaves.
  for (int k = 0; k < 3; ++k)
    if (!(L[k] > 0.0f) || !std::isfinite(L[k])) L[k] = 0.0f;
  return L;
}

void WorldGraph::bake(int width) {
  // W x W/2 equirectangular cells (environment_map.h's orientation), each the mean of S x S
  // evaluations as a light sample sees the World (2 x 2 up to 1024 columns: a small bright
  // feature, a sky's sun, is less likely to fall between them).
  const int W = std::clamp(width, 4, 8192), H = std::max(2, W / 2);
  const int S = W <= 1024 ? 2 : 1;
  baked_ = bake_directions(W, H, S, 0, [this](const Vec3& d) { return eval(d); });
}

bool WorldGraph::sample(Vec2 u, Vec3* dir, float* pdf) const {
  if (!baked_.sample(u, dir)) return false;
  *pdf = this->pdf(*dir);
  return std::isfinite(*pdf) && *pdf > 0;
}

float WorldGraph::pdf(const Vec3& dir) const {
  const float p = baked_.density(dir);
  return std::isfinite(p) ? p : 0.0f;
}

}  // namespace gp
