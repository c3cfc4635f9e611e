#include "integrators/aov.h"

#include <atomic>

#include "core/parallel.h"
#include "core/rng.h"
#include "materials/bsdf.h"

namespace gp {

// The albedo of the BSDF as the hit evaluated it (its node graph at the hit's full shading
// context: Object, Generated and normal-driven textures included; a mix's parts likewise).
RGB bsdf_albedo(const Bsdf& bsdf) {
  const BsdfParams& m = bsdf.params();
  switch (m.type) {
    case MaterialType::Emission: return RGB(0.0f);
    case MaterialType::Principled: return m.color + RGB(sqr((m.ior - 1.0f) / (m.ior + 1.0f)));  // lobes added
    case MaterialType::Clearcoat: return RGB(0.25f * 0.04f * m.clearcoat);  // its weight at normal incidence
    case MaterialType::Plastic: {
      const float f0 = sqr((m.ior - 1.0f) / (m.ior + 1.0f));
      return m.color * (1.0f - f0) + RGB(f0);
    }
    case MaterialType::Mix:
      if (m.mix_a && m.mix_b) {
        const float wa = m.mix_add ? 1.0f : 1.0f - m.mix_factor, wb = m.mix_add ? 1.0f : m.mix_factor;
        return bsdf_albedo(bsdf.component(m.mix_a)) * wa + bsdf_albedo(bsdf.component(m.mix_b)) * wb;
      }
      return m.color;
    default: return m.color;
  }
}

AovEstimator::AovEstimator(const Scene& scene, uint64_t seed, int threads)
    : scene_(scene),
      seed_(seed),
      threads_(threads),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      albedo_(size_t(width_) * height_ * 3, 0.0f),
      normal_(size_t(width_) * height_ * 3, 0.0f),
      depth_(size_t(width_) * height_, 0.0f) {}

void AovEstimator::add_pass(const std::function<bool()>& cancelled) {
  constexpr int kMaxSegments = 8;
  constexpr float kNoHitDepth = 1e10f;  // Cycles' Depth of the background
  const Camera& cam = scene_.camera;
  const Vec3 eye = cam.position();
  const Vec3 forward = normalize(cam.camera_to_world.vector(Vec3(0, 0, -1)));
  const int pass = passes_;
  // This pass's values, added to the sums only once it is whole.
  std::vector<float> albedo(albedo_.size(), 0.0f), normal(normal_.size(), 0.0f), depths(depth_.size(), 0.0f);
  std::atomic<bool> stop{false};
  parallel_for(size_t(height_), threads_, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      if (stop.load(std::memory_order_relaxed) || (cancelled && cancelled())) {
        stop = true;
        return;
      }
      for (int x = 0; x < width_; ++x) {
        const size_t i = y * width_ + x;
        Rng rng(seed_ * 0x9E3779B97F4A7C15ull + cam.pixel_key(int(x), int(y)), uint64_t(pass));
        // Motion blur: each sample at its own shutter time (a stream of its own, so a scene
        // without motion draws nothing new and keeps its passes bit for bit).
        const float t = scene_.has_motion()
                            ? Rng(seed_ * 0x9E3779B97F4A7C15ull + cam.pixel_key(int(x), int(y)), uint64_t(pass) | (1ull << 62)).uniform()
                            : 0.0f;
        const ShutterTime at(t);
        Ray ray = cam.generate_ray(Vec2(int(x) + cam.crop_x + rng.uniform(), int(y) + cam.crop_y + rng.uniform()),
                                   Vec2(rng.uniform(), rng.uniform()));
        RGB weight(1.0f);
        float depth = kNoHitDepth;
        for (int segment = 0; segment < kMaxSegments; ++segment) {
          const auto hit = scene_.intersect(ray);
          if (!hit) break;
          const Material& m = scene_.material(hit->material);
          if (m.is_pass_through()) {  // a light object: crossed, as Cycles' lights
            const bool camera = ray.camera;
            ray = Ray(offset_ray_origin(hit->p, hit->ng, ray.d), ray.d);
            ray.camera = camera;
            continue;
          }
          if (depth == kNoHitDepth) depth = dot(hit->p - eye, forward);
          const Bsdf bsdf = scene_.bsdf(*hit);
          if (!bsdf.is_delta()) {
            const RGB a = weight * bsdf_albedo(bsdf);
            for (int k = 0; k < 3; ++k) {
              albedo[3 * i + k] = a[k];
              normal[3 * i + k] = hit->ns[k];
            }
            break;
          }
          const Vec3 wo = hit->frame.to_local(-ray.d);
          const auto s = bsdf.sample(wo, rng.uniform(), Vec2(rng.uniform(), rng.uniform()));
          if (!s || !(s->pdf > 0)) break;
          weight *= s->f * (std::abs(s->wi.z) / s->pdf);
          const Vec3 wi = hit->frame.to_world(s->wi);
          ray = Ray(offset_ray_origin(hit->p, hit->ng, wi), wi);
        }
        depths[i] = depth;
      }
    }
  });
  if (stop) return;
  for (size_t k = 0; k < albedo.size(); ++k) albedo_[k] += albedo[k];
  for (size_t k = 0; k < normal.size(); ++k) normal_[k] += normal[k];
  for (size_t k = 0; k < depths.size(); ++k) depth_[k] += depths[k];
  ++passes_;
}

void AovEstimator::develop(Film& film) const {
  const float inv = passes_ > 0 ? 1.0f / static_cast<float>(passes_) : 0.0f;
  Pass& a = film.add_pass(pass::kAlbedo, 3);
  Pass& n = film.add_pass(pass::kNormal, 3);
  Pass& d = film.add_pass(pass::kDepth, 1);
  a.data.resize(albedo_.size());
  n.data.resize(normal_.size());
  d.data.resize(depth_.size());
  for (size_t k = 0; k < albedo_.size(); ++k) a.data[k] = albedo_[k] * inv;
  for (size_t k = 0; k < normal_.size(); ++k) n.data[k] = normal_[k] * inv;
  for (size_t k = 0; k < depth_.size(); ++k) d.data[k] = depth_[k] * inv;
}

}  // namespace gp
