// The World's emission as a function of direction with a sampler: one interface for an image
// (environment_map.h), a procedural sky (sky.h), a constant colour, and a sum of them (Cycles'
// Mix / Add Shader of Backgrounds: the World's radiance is the weighted sum of theirs).
//
// A sum is sampled by one-sample MIS over its terms (Veach's mixture): a term picked in
// proportion to its power, then a direction from it; the density of a direction is the
// mixture's, sum_i p_i pdf_i(d), so next-event estimation, MIS with BSDF rays and photon
// emission see the combined emission's density (Veach 1997 §9.2.4, the balance heuristic as
// one mixture density).
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/math.h"
#include "core/sampling.h"

namespace gp {

// A direction function baked for importance sampling: W x H equirectangular cells (Cycles'
// projection, environment_map.h), each the mean of S x S evaluations of `radiance`; the
// sampling density is each cell's luminance times sin(theta) (the standard construction),
// floored at 1e-3 of its mean so that every cell lit in part has density (uniform when all is
// black); `integral` is the radiance integrated over the sphere (W sr^-1 m^-2 x sr) per channel.
struct BakedDirections {
  PiecewiseConstant2D grid;
  RGB integral{0.0f};
  // A direction by the grid (false: none); its solid-angle density is density().
  bool sample(Vec2 u, Vec3* dir) const;
  // The grid's solid-angle density at a unit direction: its uv density over the equirectangular
  // map's Jacobian 2 pi^2 sin(theta); 0 at the poles (not checked for finiteness).
  float density(const Vec3& dir) const;
};
BakedDirections bake_directions(int W, int H, int S, int threads, const std::function<RGB(const Vec3&)>& radiance);

// K direction functions baked together over one such grid (one call gives all K values, so a
// World graph's program runs once per direction): per term its cells' luminance and its
// integral, kept so that a weighted sum of the terms is baked again without evaluating them
// (a World graph whose Mix / Add of Backgrounds is re-weighted: world_graph.h).
struct BakedTerms {
  int W = 0, H = 0;
  std::vector<std::vector<float>> luminance;      // per term: W x H cells (the means of S x S values)
  std::vector<std::array<double, 3>> integral;    // per term: over the sphere
  double uniform_integral = 0;                    // 1 over the sphere by the same quadrature (about 4 pi)
  size_t bytes() const;
};
// `radiance(d, out)` writes the K terms' values at unit direction d to out[0 .. K-1].
BakedTerms bake_direction_terms(int W, int H, int S, int threads, int K,
                                const std::function<void(const Vec3&, RGB*)>& radiance);
// The bake of sum_k weights[k] x term k + `constant` (a uniform radiance): bake_directions'
// grid and integral of that sum (luminance is linear: the same cells up to float rounding; bit
// for bit bake_directions' for one term of weight 1 and no constant). Cells whose weighted sum
// is negative count as black.
BakedDirections combine_direction_terms(const BakedTerms& terms, const std::vector<float>& weights, RGB constant);

class BackgroundTerm {
 public:
  virtual ~BackgroundTerm() = default;
  // Radiance arriving from unit world direction `dir` (strength included).
  virtual RGB eval(const Vec3& dir) const = 0;
  // Radiance seen by a path's ray of state `ray` leaving the scene along `dir`: the same but
  // for a World whose graph reads Light Path (world_graph.h).
  virtual RGB eval(const Vec3& dir, const RayState& ray) const { (void)ray; return eval(dir); }
  // A unit direction towards the World and its density per solid angle (> 0), or false.
  virtual bool sample(Vec2 u, Vec3* dir, float* pdf) const = 0;
  // The density sample() gives `dir`, per solid angle.
  virtual float pdf(const Vec3& dir) const = 0;
  // sample() with the radiance eval() gives the direction drawn: a term that knows the point it
  // drew (an image's texel position) looks it up there instead of projecting the direction back.
  virtual bool sample_eval(Vec2 u, Vec3* dir, float* pdf, RGB* radiance) const {
    if (!sample(u, dir, pdf)) return false;
    *radiance = eval(*dir);
    return true;
  }
  // eval(dir, ray) and pdf(dir) together (a BSDF ray that left the scene, weighed by MIS): one
  // projection of the direction where the term can share it.
  virtual RGB eval_pdf(const Vec3& dir, const RayState& ray, float* pdf) const {
    *pdf = this->pdf(dir);
    return eval(dir, ray);
  }
  // The radiance's integral over the sphere (the light's power, for light selection and for
  // picking a term of a sum).
  virtual RGB integral() const = 0;
  // What it is, as text (which image, turned and scaled how; which sky): a run's scene
  // fingerprint (distributed/run_info.cpp) tells two Worlds apart by it.
  virtual std::string identity() const = 0;
};

// A constant radiance from every direction, sampled uniformly over the sphere.
class ConstantBackground final : public BackgroundTerm {
 public:
  explicit ConstantBackground(RGB radiance) : radiance_(radiance) {}
  RGB eval(const Vec3&) const override { return radiance_; }
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override;
  float pdf(const Vec3&) const override { return uniform_sphere_pdf(); }
  RGB integral() const override { return radiance_ * (4.0f * kPi); }
  std::string identity() const override;

 private:
  RGB radiance_;
};

// A background times a constant colour: the Background's Color x Strength over a shared sky
// (sky.h's cache), so that a strength edit reuses the precomputed sky.
class ScaledBackground final : public BackgroundTerm {
 public:
  ScaledBackground(std::shared_ptr<const BackgroundTerm> term, RGB scale) : term_(std::move(term)), scale_(scale) {}
  RGB eval(const Vec3& dir) const override { return term_->eval(dir) * scale_; }
  RGB eval(const Vec3& dir, const RayState& ray) const override { return term_->eval(dir, ray) * scale_; }
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override { return term_->sample(u, dir, pdf); }
  float pdf(const Vec3& dir) const override { return term_->pdf(dir); }
  RGB integral() const override { return term_->integral() * scale_; }
  std::string identity() const override;
  const BackgroundTerm& term() const { return *term_; }

 private:
  std::shared_ptr<const BackgroundTerm> term_;
  RGB scale_;
};

// A background looked up along a linear transform of the direction: the texture's Vector
// from a Texture Coordinate -> Mapping chain (a Sky Texture turned by a Mapping). The term sees
// normalize(M d) (Cycles' sky reads a unit vector: its spherical angles); a direction drawn from
// the term, v, is d = normalize(M^-1 v), its density the term's times the Jacobian of
// d -> normalize(M d) on the sphere, |det M| / |M d|^3.
class TransformedBackground final : public BackgroundTerm {
 public:
  // Throws std::invalid_argument for a singular or non-finite matrix.
  TransformedBackground(std::shared_ptr<const BackgroundTerm> term, const float to_term[3][3]);
  RGB eval(const Vec3& dir) const override;
  RGB eval(const Vec3& dir, const RayState& ray) const override;
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override;
  float pdf(const Vec3& dir) const override;
  // The term's (exact for a rotation; a selection weight otherwise, as EnvironmentMap's).
  RGB integral() const override { return term_->integral(); }
  std::string identity() const override;

 private:
  Vec3 to_term(const Vec3& d) const;
  std::shared_ptr<const BackgroundTerm> term_;
  float m_[3][3], inv_[3][3];
  float det_ = 1.0f;
};

// The sum of several backgrounds (each already scaled by its Mix factor and strength).
class BackgroundSum final : public BackgroundTerm {
 public:
  // Terms whose integral is black are dropped; throws std::invalid_argument when none is left.
  explicit BackgroundSum(std::vector<std::shared_ptr<const BackgroundTerm>> terms);
  RGB eval(const Vec3& dir) const override;
  RGB eval(const Vec3& dir, const RayState& ray) const override;
  bool sample(Vec2 u, Vec3* dir, float* pdf) const override;
  float pdf(const Vec3& dir) const override;
  RGB integral() const override;
  std::string identity() const override;
  const std::vector<std::shared_ptr<const BackgroundTerm>>& terms() const { return terms_; }

 private:
  std::vector<std::shared_ptr<const BackgroundTerm>> terms_;
  DiscreteDistribution pick_;  // by each term's power
};

}  // namespace gp
