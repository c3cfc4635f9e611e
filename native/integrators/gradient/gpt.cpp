// Gradient-domain path tracing (see gpt.h for the method, parameters and references).
#include "integrators/gradient/gpt.h"
#include "integrators/gradient/gradient_passes.h"

#include <chrono>
#include <mutex>

#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/shift/shift.h"
#include "integrators/lobe_split.h"
#include "integrators/paths/medium_walk.h"
#include "materials/bsdf.h"

namespace gp {

namespace {

constexpr int kOffsetX[4] = {1, -1, 0, 0};
constexpr int kOffsetY[4] = {0, 0, 1, -1};
// Right and down offsets estimate I(offset) - I(base); left and up estimate I(base) - I(offset),
// the forward difference stored at the offset pixel.
constexpr float kSign[4] = {1, -1, 1, -1};

enum class Link { NotConnected, RecentlyConnected, Connected };

// One offset path while the base path is traced.
struct Offset {
  bool exists = false;        // inside the image
  ShiftFailure failure = ShiftFailure::None;
  Link link = Link::NotConnected;
  std::optional<SurfaceHit> hit;  // own vertex while NotConnected
  Ray ray;                     // own ray while NotConnected
  Vec3 wo;                     // world direction towards the previous vertex (RecentlyConnected)
  RGB beta{1.0f};              // throughput in the base path's measure (Jacobians included)
  double ratio = 1;            // p(T x) |T'| / p(x) of the prefix, for the gradient MIS
  float prev_pdf = 0;          // own solid-angle BSDF pdf of the last segment (its NEE/BSDF MIS)
  Vec3 prev_p;                 // own previous vertex
  // Where a light is hidden from some kinds of ray: its lobes at the previous vertex, for the
  // emission its BSDF ray finds (lobe_split.h, in the base's measure with the shift's Jacobian).
  LobeSplit split;
  float jacobian = 1;
  bool alive() const { return exists && failure == ShiftFailure::None; }
};

// One base path and its four offsets while trace() follows them, vertex by vertex: the state
// the shift carries, with one member function per step of the walk (emission found, the
// offsets' vertices matched, next-event estimation shifted to the same light point, the BSDF
// sample and each offset's shift, Russian roulette).
struct PathPair {
  const Scene& scene_;
  const LightSet& lights;
  Sampler& rng;
  RayCounts& rays;
  std::map<std::string, double>* failures;
  // Cycles' per-kind switches: every bounce ray carries its lobe (Ray::bounce), the offsets'
  // rays and reconnections the base's, so an offset sees the scene as the base's ray of that
  // kind does (each segment of a pair is traced among the same surfaces, and the shift stays
  // invertible: the inverse shift follows the same lobes). Lights hidden from some kinds weigh
  // BSDF hits by the lobes that see them, as the path tracer (lobe_split.h).
  const bool split_lobes;
  LobeSplit prev;  // the base's lobes at its previous vertex (split_lobes)
  GradientPathTracer::Sample out;
  Offset off[4];
  Ray ray;
  RGB beta{1.0f};
  bool specular_bounce = true, all_delta = true;  // the camera ray: MIS skipped (Cycles), carried on only by a transparent pass
  float prev_pdf = 0;
  Vec3 prev_p;
  std::optional<SurfaceHit> hit;
  bool crossed = false, transparent_pass = false;  // what the last scatter did (not a bounce)

  PathPair(const Scene& scene, Vec2 film, Vec2 lens, Sampler& sampler, RayCounts& ray_counts,
           std::map<std::string, double>* fails, int pixel_x, int pixel_y, int width, int height)
      : scene_(scene), lights(scene.light_set()), rng(sampler), rays(ray_counts), failures(fails),
        split_lobes(scene.lights_hidden_from_some_lobes()) {
    out.primal = out.direct = RGB(0.0f);
    for (int d = 0; d < 4; ++d) {
      out.diff[d] = RGB(0.0f);
      // `film` is in the whole image's pixels (camera.h start_pixel); the film is the crop window.
      const int px = (pixel_x >= 0 ? pixel_x : static_cast<int>(film.x)) - scene_.camera.crop_x + kOffsetX[d],
                py = (pixel_y >= 0 ? pixel_y : static_cast<int>(film.y)) - scene_.camera.crop_y + kOffsetY[d];
      out.has[d] = off[d].exists = px >= 0 && px < width && py >= 0 && py < height;
      if (!off[d].exists) continue;
      // Same sub-pixel position and lens sample one pixel over: the camera's Jacobian is 1.
      off[d].ray = scene_.camera.generate_ray(Vec2(film.x + kOffsetX[d], film.y + kOffsetY[d]), lens);
    }
    ray = scene_.camera.generate_ray(film, lens);
    ++rays.closest;
    hit = scene_.intersect(ray);
    for (int d = 0; d < 4; ++d)
      if (off[d].alive()) {
        ++rays.closest;
        off[d].hit = scene_.intersect(off[d].ray);
      }
  }

  void fail(Offset& o, ShiftFailure f) {
    o.failure = f;
    if (failures) (*failures)[std::string(failure_stat_name(f))] += 1;
  }
  // One contribution of the base (c) and of each offset (c_off[d]) to their pixels, made with
  // the same strategy; `ratio[d]` = p(T x)|T'| / p(x) of the whole strategy's path.
  void add(const RGB& c, const RGB* c_off, const double* ratio, bool direct_only) {
    if (direct_only) {
      out.direct += c;
      return;
    }
    out.primal += c;
    for (int d = 0; d < 4; ++d) {
      if (!off[d].exists) continue;
      const bool ok = off[d].alive();
      const float w = ok ? static_cast<float>(1.0 / (1.0 + ratio[d])) : 1.0f;  // balance heuristic
      const RGB co = ok ? c_off[d] : RGB(0.0f);
      out.diff[d] += (co - c) * (w * kSign[d]);
    }
  }

  // ---- Emission found by the last ray (camera or BSDF sample) ----
  void emission(int depth) {
    RGB c(0.0f), c_off[4];
    double ratio[4];
    float w_base = 1.0f;
    // A BSDF hit on a light hidden from some kinds (lobe_split.h); `o` an offset, else the base.
    auto split_hit = [&](int light, const RGB& Le, float pdf_light, const Offset* o) -> std::optional<RGB> {
      const uint8_t vis = light >= 0 ? lights.lights()[light].visible_lobes : kAllLobes;
      if (depth == 0 || !split_lobes || vis == kAllLobes) return std::nullopt;
      if (lights.lights()[light].lit_by_bsdf_rays_only()) {  // the World (lobe_split.h), full weight
        if (!o) return prev.weigh_world(Le, vis, specular_bounce, beta);
        return o->split.weigh_world(Le, vis, specular_bounce, o->beta, prev.lobe_share(prev.lobe));
      }
      if (!o) return prev.weigh(Le, vis, specular_bounce, beta, pdf_light);
      return o->split.weigh(Le, vis, specular_bounce, o->beta, pdf_light, o->jacobian, prev.pdf_of(vis));
    };
    if (!hit) {
      // The World's Camera switch (its sky seen by camera rays; directly seen light has no
      // gradient offsets here, direct_only below).
      const RGB Le = depth == 0 && !lights.environment_visible_to_camera() ? RGB(0.0f) : lights.environment_radiance(ray);
      if (!(depth == 0 || specular_bounce)) w_base = power_heuristic(prev_pdf, lights.pdf_environment(ray.d));
      c = split_hit(lights.environment(), Le, lights.pdf_environment(ray.d), nullptr).value_or(beta * Le * w_base);
    } else if (hit->light >= 0) {
      const RGB Le = lights.area_radiance(hit->light, -ray.d, hit->p, &hit->ray);
      const float pdf_light = depth == 0 ? 0.0f : lights.pdf_area(hit->light, prev_p, hit->p, ray.d);
      if (!(depth == 0 || specular_bounce)) w_base = power_heuristic(prev_pdf, pdf_light);
      c = split_hit(hit->light, Le, pdf_light, nullptr).value_or(beta * Le * w_base);
    }
    const bool direct_only = all_delta;  // emitters seen directly or through delta vertices only
    if (!direct_only) {
      for (int d = 0; d < 4; ++d) {
        Offset& o = off[d];
        c_off[d] = RGB(0.0f);
        ratio[d] = o.ratio;
        if (!o.alive()) continue;
        // Emission Le from `light` (-1: none) with the offset's own MIS density pdf_light.
        auto found = [&](int light, const RGB& Le, float pdf_light) {
          return split_hit(light, Le, pdf_light, &o)
              .value_or(o.beta * Le * (specular_bounce ? 1.0f : power_heuristic(o.prev_pdf, pdf_light)));
        };
        if (o.link == Link::Connected) {  // same vertices and last segment, own MIS pdf
          if (!hit) c_off[d] = found(lights.environment(), lights.environment_radiance(ray), lights.pdf_environment(ray.d));
          else if (hit->light >= 0)
            c_off[d] = found(hit->light, lights.area_radiance(hit->light, -ray.d),
                             lights.pdf_area(hit->light, prev_p, hit->p, ray.d));
        } else if (o.link == Link::RecentlyConnected) {  // reconnected onto this very vertex
          if (hit && hit->light >= 0) {
            c_off[d] = found(hit->light, lights.area_radiance(hit->light, o.wo),
                             lights.pdf_area(hit->light, o.prev_p, hit->p, -o.wo));
          } else if (!hit) {  // reconnected at infinity: same direction
            c_off[d] = found(lights.environment(), lights.environment_radiance(ray), lights.pdf_environment(ray.d));
          }
        } else {  // own vertex
          if (!o.hit) {
            if (hit) {
              fail(o, ShiftFailure::Missed);
              continue;
            }
            c_off[d] = found(lights.environment(), lights.environment_radiance(o.ray), lights.pdf_environment(o.ray.d));
          } else if (!hit) {
            fail(o, ShiftFailure::Occluded);  // the base escaped, the offset did not
            continue;
          } else if (o.hit->light >= 0) {
            c_off[d] = found(o.hit->light, lights.area_radiance(o.hit->light, -o.ray.d),
                             lights.pdf_area(o.hit->light, o.prev_p, o.hit->p, o.ray.d));
          }
        }
      }
    }
    add(c, c_off, ratio, direct_only);
  }

  // ---- Offset vertices: kinds must match for the shift to be invertible ----
  void match_offsets(VertexKind kind) {
    for (int d = 0; d < 4; ++d) {
      Offset& o = off[d];
      if (!o.alive() || o.link != Link::NotConnected) continue;
      if (!o.hit) {
        fail(o, ShiftFailure::Missed);
        continue;
      }
      if (const Bsdf ob = scene_.bsdf(*o.hit); classify_vertex(ob) != kind || ob.is_black())
        fail(o, ShiftFailure::NotInvertible);
    }
  }

  // ---- Emitter sampling (next-event estimation), shifted to the same light point ----
  void next_event(const Bsdf& bsdf, const Vec3& wo) {
    if (!bsdf.is_delta() && !lights.empty()) {
      const float u_light = rng.uniform();
      const Vec2 u2(rng.uniform(), rng.uniform());
      RGB c(0.0f), c_off[4];
      double ratio[4];
      // Radiance through one vertex from the light sample drawn with (u_light, u2), with its
      // NEE/BSDF MIS weight; 0 if blocked. `visible` holds the shadow ray's transmittance
      // (transparent surfaces filter it: paths/medium_walk.h) once known, and skips the ray
      // then: an offset at the base's vertex and light point gets the base's factor, so the
      // shift stays consistent.
      std::optional<RGB> base_visible;  // unknown
      auto nee = [&](const SurfaceHit& v, const Bsdf& b, const Vec3& wo_l, std::optional<RGB>* visible) -> RGB {
        auto ls = lights.sample_li(v.p, u_light, u2);
        if (!ls || ls->pdf <= 0 || ls->L.is_black()) return RGB(0.0f);
        if (ls->light >= 0 && lights.lights()[ls->light].lit_by_bsdf_rays_only()) return RGB(0.0f);  // BSDF rays find it
        // A light hidden from some kinds lights only the lobes that see it (as the path tracer).
        const uint8_t vis = ls->light >= 0 ? lights.lights()[ls->light].visible_lobes : kAllLobes;
        const Vec3 wi = v.frame.to_local(ls->wi);
        const RGB f = b.eval(wo_l, wi, TransportMode::Radiance, vis) * std::abs(wi.z);
        if (f.is_black()) return RGB(0.0f);
        RGB T;
        if (!visible || !*visible) {
          ++rays.shadow;
          const ChannelValues t = ShadowTest(scene_, nullptr).transmittance(v.p, &v.ng, *ls, {.state = v.ray});
          T = RGB(t[0], t[1], t[2]);
          if (visible) *visible = T;
        } else {
          T = **visible;
        }
        if (T.is_black()) return RGB(0.0f);
        const float w = ls->delta ? 1.0f : power_heuristic(ls->pdf, b.pdf(wo_l, wi, vis));
        return f * T * ls->L * (w / ls->pdf);
      };
      const RGB L_base = nee(*hit, bsdf, wo, &base_visible);
      c = beta * L_base;
      for (int d = 0; d < 4; ++d) {
        Offset& o = off[d];
        c_off[d] = RGB(0.0f);
        ratio[d] = o.ratio;  // the light point is shared: same area density on both sides
        if (!o.alive()) continue;
        if (o.link == Link::Connected) {  // same vertex, same wo: same value
          c_off[d] = o.beta * L_base;
        } else if (o.link == Link::RecentlyConnected) {  // same vertex and light point: same visibility
          c_off[d] = o.beta * nee(*hit, bsdf, hit->frame.to_local(o.wo), &base_visible);
        } else {
          const Bsdf ob = scene_.bsdf(*o.hit);
          c_off[d] = o.beta * nee(*o.hit, ob, o.hit->frame.to_local(-o.ray.d), nullptr);
        }
      }
      add(c, c_off, ratio, false);
    }
  }

  // ---- BSDF sampling of the base, then the shift of each offset; false: the path ends ----
  bool scatter(const Bsdf& bsdf, const Vec3& wo, VertexKind kind) {
    const float uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const auto bs = bsdf.sample(wo, uc, u);
    if (!bs || bs->pdf <= 0 || bs->f.is_black()) return false;
    const RGB base_factor = bs->f * (std::abs(bs->wi.z) / bs->pdf);
    const Vec3 wi_world = hit->frame.to_world(bs->wi);
    Ray next_ray(offset_ray_origin(hit->p, hit->ng, wi_world), wi_world);
    // Its kind: the lobe sampled, or across a light object (a pass-through surface casting no
    // shadow) or a Transparent BSDF the kind it had (a transparent bounce counts in its state
    // only; neither is a bounce: `not_bounce`, as in paths/camera_path.h).
    const Material& material = scene_.material(hit->material);
    crossed = material.is_pass_through() && !material.transparent_shadow();
    transparent_pass = !crossed && is_transparent_pass(*bs);
    const bool not_bounce = crossed || transparent_pass;
    next_ray.bounce = not_bounce ? ray.bounce : bs->lobe;
    next_ray.camera = not_bounce && ray.camera;
    next_ray.state = crossed ? ray.state : next_ray_state(ray.state, bs->lobe, bs->transmission, bs->delta, bs->eta);
    if (split_lobes) {
      prev.beta = beta;
      prev.lobe = bs->lobe;
      if (!bs->delta) prev.fill(bsdf, wo, bs->wi);
    }
    // An offset's lobes where it scattered (after its shift), `f_wo`/`f_wi` local at its vertex.
    auto split_at = [&](Offset& o, const Bsdf& b, const Vec3& f_wo, const Vec3& f_wi, float jacobian) {
      if (!split_lobes) return;
      o.split.beta = o.beta;
      o.split.lobe = bs->lobe;
      o.jacobian = jacobian;
      if (!bs->delta) o.split.fill(b, f_wo, f_wi);
    };
    ++rays.closest;
    const std::optional<SurfaceHit> next = scene_.intersect(next_ray);
    // Reconnection needs diffuse here and a diffuse (or emitting) vertex next, or no vertex at all.
    const bool next_diffuse =
        !next || next->light >= 0 || classify_vertex(scene_.bsdf(*next)) == VertexKind::Diffuse;
    const bool can_reconnect = kind == VertexKind::Diffuse && next_diffuse;
    // Through a Transparent BSDF (shadow rays pass it, paths/medium_walk.h): the base and its
    // offsets keep the MIS state of the vertex before (as the path tracer, camera_path.h).
    const bool transparent = is_transparent_pass(*bs) && scene_.material(hit->material).transparent_shadow();
    float kept_pdf[4];
    Vec3 kept_p[4];
    for (int d = 0; d < 4; ++d) {
      kept_pdf[d] = off[d].prev_pdf;
      kept_p[d] = off[d].prev_p;
    }

    // A random-walk lobe (Multiscatter GGX) draws directions of unknown density: an offset's
    // f / p(base) cannot be formed, so offsets not sharing the base's vertex stop here (a failed
    // shift keeps the gradient unbiased; KMA15 §4.2).
    const bool walked = bs->stochastic;
    for (int d = 0; d < 4; ++d) {
      Offset& o = off[d];
      if (!o.alive()) continue;
      if (walked && o.link != Link::Connected) {
        fail(o, ShiftFailure::NotInvertible);
        continue;
      }
      if (o.link == Link::Connected) {
        split_at(o, bsdf, wo, bs->wi, 1.0f);
        o.beta *= base_factor;
        o.prev_pdf = bs->pdf;
        o.prev_p = hit->p;
        continue;
      }
      if (o.link == Link::RecentlyConnected) {  // shared vertex, own incoming direction
        const Vec3 owo = hit->frame.to_local(o.wo);
        const float pdf = bsdf.pdf(owo, bs->wi);
        split_at(o, bsdf, owo, bs->wi, 1.0f);
        o.beta *= bsdf.eval(owo, bs->wi) * (std::abs(bs->wi.z) / bs->pdf);
        o.ratio *= pdf / bs->pdf;
        o.prev_pdf = pdf;
        o.prev_p = hit->p;
        o.link = Link::Connected;
        continue;
      }
      const SurfaceHit& ov = *o.hit;
      const Bsdf ob = scene_.bsdf(ov);  // with its normals (a normal map's bump shadowing), as the base's
      const Vec3 owo = ov.frame.to_local(-o.ray.d);
      if (can_reconnect) {
        Vec3 wi_o;
        double jac = 1.0;
        if (next) {  // ---- reconnection onto the base's next vertex ----
          const ReconnectShift rs = shift_reconnect(hit->p, ov.p, next->p, next->ng);
          if (!rs.ok()) {
            fail(o, rs.failure);
            continue;
          }
          ++rays.shadow;
          if (scene_.hides_between(ov.p, ov.ng, next->p, next->ng, next_ray.bounce)) {
            fail(o, ShiftFailure::Occluded);
            continue;
          }
          wi_o = rs.wi;
          jac = rs.jacobian;
          o.link = Link::RecentlyConnected;
          o.wo = -wi_o;
        } else {  // ---- reconnection at infinity: same direction, Jacobian 1 ----
          wi_o = wi_world;
          o.ray = Ray(offset_ray_origin(ov.p, ov.ng, wi_o), wi_o);
          o.ray.bounce = next_ray.bounce;
          o.ray.camera = next_ray.camera;
          o.ray.state = next_ray.state;
          ++rays.closest;
          const auto oh = scene_.intersect(o.ray);
          if (oh) {
            fail(o, ShiftFailure::Occluded);
            continue;
          }
          o.hit.reset();
        }
        const Vec3 wi_l = ov.frame.to_local(wi_o);
        const float pdf = ob.pdf(owo, wi_l);
        split_at(o, ob, owo, wi_l, static_cast<float>(jac));
        o.beta *= ob.eval(owo, wi_l) * static_cast<float>(std::abs(wi_l.z) * jac / bs->pdf);
        o.ratio *= pdf * jac / bs->pdf;
        o.prev_pdf = pdf;
        o.prev_p = ov.p;
        continue;
      }
      // ---- half-vector copy (glossy and non-reconnectable diffuse vertices) or delta lobe ----
      const ScatterShift ss = shift_scatter(ob, wo, bs->wi, bs->delta, bs->transmission, owo);
      if (!ss.ok()) {
        fail(o, ss.failure);
        continue;
      }
      split_at(o, ob, owo, ss.wi, static_cast<float>(ss.jacobian));
      o.beta *= ss.f_cos * static_cast<float>(ss.jacobian / bs->pdf);
      o.ratio *= ss.pdf * ss.jacobian / bs->pdf;
      o.prev_pdf = ss.pdf;
      o.prev_p = ov.p;
      const Vec3 wi_w = ov.frame.to_world(ss.wi);
      o.ray = Ray(offset_ray_origin(ov.p, ov.ng, wi_w), wi_w);
      o.ray.bounce = next_ray.bounce;
      o.ray.camera = next_ray.camera;
      o.ray.state = next_ray.state;
      ++rays.closest;
      o.hit = scene_.intersect(o.ray);
    }

    beta *= base_factor;
    if (transparent) {
      for (int d = 0; d < 4; ++d) {
        off[d].prev_pdf = kept_pdf[d];
        off[d].prev_p = kept_p[d];
      }
    } else {
      specular_bounce = bs->delta;
      prev_pdf = bs->pdf;
      prev_p = hit->p;
    }
    all_delta = all_delta && bs->delta;
    ray = next_ray;
    hit = next;
    return true;
  }

  // ---- Russian roulette: one decision for the base and its offsets; false: the path ends ----
  bool survive() {
    const float q = std::max(0.05f, 1.0f - beta.max_component());
    if (rng.uniform() < q) return false;
    beta = beta / (1.0f - q);
    prev.beta = prev.beta / (1.0f - q);
    for (Offset& o : off) {
      o.beta = o.beta / (1.0f - q);
      o.split.beta = o.split.beta / (1.0f - q);
    }
    return true;
  }
};

}  // namespace

GradientPathTracer::GradientPathTracer(const Scene& scene, const Params& params)
    : scene_(scene),
      max_depth_(params.get<int>("max_depth")),
      rr_depth_(params.get<int>("rr_depth")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      seed_(params.get<uint64_t>("seed")),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()) {
  check_image_size(width_, height_);  // the parameters are checked by their declarations (methods.cpp)
  recon_ = gradient_recon_options(params, threads_);
  const size_t n = static_cast<size_t>(width_) * height_;
  primal_.assign(3 * n, 0.0);
  direct_.assign(3 * n, 0.0);
  grad_.assign(12 * n, 0.0);
  samples_.assign(n, 0);
}

GradientPathTracer::Sample GradientPathTracer::trace(Vec2 film, Vec2 lens, Sampler& rng, RayCounts& rays,
                                                     std::map<std::string, double>* failures, int pixel_x,
                                                     int pixel_y) const {
  PathPair p(scene_, film, lens, rng, rays, failures, pixel_x, pixel_y, width_, height_);
  constexpr int kMaxCrossings = 8;  // light objects crossed without a bounce (camera_path.h)
  int crossings = 0;
  for (int depth = 0;; ++depth) {
    p.emission(depth);
    if (!p.hit || depth + 1 >= max_depth_ || transparent_done(scene_.transparent_bounces, p.ray.state)) break;
    const Bsdf bsdf = scene_.bsdf(*p.hit);
    if (bsdf.is_black()) break;
    const Vec3 wo = p.hit->frame.to_local(-p.ray.d);
    if (wo.z == 0) break;
    const VertexKind kind = classify_vertex(bsdf);
    p.match_offsets(kind);
    p.next_event(bsdf, wo);
    if (!p.scatter(bsdf, wo, kind)) break;
    // A transparent bounce or a light object crossed is no bounce (Cycles' path_state_next).
    if (p.transparent_pass || (p.crossed && ++crossings <= kMaxCrossings)) --depth;
    if (depth + 1 >= rr_depth_ && !p.survive()) break;
  }
  return p.out;
}

void GradientPathTracer::iterate(ProgressSink* sink) {
  const auto start = std::chrono::steady_clock::now();
  const uint64_t pass = static_cast<uint64_t>(stats_.passes);
  std::atomic<int64_t> closest{0}, shadow{0}, paths{0}, invalid{0};
  std::mutex failures_mutex;
  std::map<std::string, double> failures;
  parallel_for_tiles(
      width_, height_, tile_size_, threads_,
      [&](const Tile& tile) {
        RayCounts tile_rays;
        int64_t tile_paths = 0, tile_invalid = 0;
        std::map<std::string, double> tile_failures;
        for (int y = tile.y0; y < tile.y1; ++y)
          for (int x = tile.x0; x < tile.x1; ++x) {
            const size_t pixel = static_cast<size_t>(y) * width_ + x;
            auto [rng, film, lens, time] = start_pixel(scene_.camera, seed_, pass, x, y);
            // Motion blur: the base path and its offsets at the base's shutter time (core/math.h).
            const ShutterTime at_time(time);
            RngSampler sampler(rng);
            const Sample s = trace(film, lens, sampler, tile_rays, &tile_failures, x + scene_.camera.crop_x,
                                   y + scene_.camera.crop_y);
            ++tile_paths;
            ++samples_[pixel];
            bool finite = s.primal.is_finite() && s.direct.is_finite();
            for (const RGB& g : s.diff) finite = finite && g.is_finite();
            if (!finite) {  // discard and count: NaN/Inf never reaches a pass
              ++tile_invalid;
              continue;
            }
            for (int c = 0; c < 3; ++c) {
              primal_[3 * pixel + c] += s.primal[c];
              direct_[3 * pixel + c] += s.direct[c];
              for (int d = 0; d < 4; ++d) grad_[12 * pixel + 3 * d + c] += s.diff[d][c];
            }
          }
        closest += tile_rays.closest;
        shadow += tile_rays.shadow;
        paths += tile_paths;
        invalid += tile_invalid;
        std::lock_guard<std::mutex> lock(failures_mutex);
        for (const auto& [k, v] : tile_failures) failures[k] += v;
      },
      [sink] { return sink && sink->cancelled(); });
  stats_.passes += 1;
  stats_.rays += closest + shadow;
  stats_.shadow_rays += shadow;
  stats_.paths += paths;
  stats_.invalid_samples += invalid;
  for (const auto& [k, v] : failures) stats_.extra[k] += v;
  stats_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void GradientPathTracer::develop(Film& film) const {
  if (film.width() != width_ || film.height() != height_) film = Film(width_, height_);
  const size_t n = samples_.size();
  std::vector<double> primal(3 * n), direct(3 * n), gx(3 * n, 0.0), gy(3 * n, 0.0);
  auto inv = [&](size_t i) { return samples_[i] ? 1.0 / samples_[i] : 0.0; };
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      for (int c = 0; c < 3; ++c) {
        primal[3 * i + c] = primal_[3 * i + c] * inv(i);
        direct[3 * i + c] = direct_[3 * i + c] * inv(i);
        // Each difference from both of its pixels; their MIS weights sum to one.
        if (x + 1 < width_)
          gx[3 * i + c] = grad_[12 * i + 3 * kRight + c] * inv(i) + grad_[12 * (i + 1) + 3 * kLeft + c] * inv(i + 1);
        if (y + 1 < height_) {
          const size_t j = i + width_;
          gy[3 * i + c] = grad_[12 * i + 3 * kDown + c] * inv(i) + grad_[12 * j + 3 * kUp + c] * inv(j);
        }
      }
    }
  develop_gradient_passes(film, primal, gx, gy, direct, width_, height_, recon_);
}

}  // namespace gp
