// Gradient-domain Metropolis light transport in primary sample space (see gdmlt.h for the method,
// parameters and references).
#include "integrators/gradient/gdmlt.h"
#include "integrators/gradient/gradient_passes.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "core/parallel.h"
#include "core/sampler.h"
#include "reconstruction/poisson.h"

namespace gp {

namespace {

// Third Rng::for_key component of each kind of stream (the first is the seed).
constexpr uint64_t kBootstrapKey = 0x626f6f7473747261ULL;  // bootstrap sample i
constexpr uint64_t kStartKey = 0x7374617274ULL;            // chain c's choice of start state
constexpr uint64_t kChainKey = 0x636861696eULL;            // chain c's mutations

// Sum of the channels' absolute values in luminance weights: zero only for a black colour.
double abs_luminance(const RGB& c) {
  return 0.2126 * std::abs(c.r) + 0.7152 * std::abs(c.g) + 0.0722 * std::abs(c.b);
}

bool is_finite(const GradientPathTracer::Sample& s) {
  bool ok = s.primal.is_finite() && s.direct.is_finite();
  for (const RGB& g : s.diff) ok = ok && g.is_finite();
  return ok;
}

// One weighted sample to add to the accumulators: sample * scale at `pixel`.
struct Splat {
  int pixel;
  double scale;
  GradientPathTracer::Sample sample;
};

}  // namespace

// What one chain did in one pass, merged in chain order.
struct GdmltChainResult {
  std::vector<Splat> splats;
  std::vector<int> visits;  // pixel of the chain's state after each mutation
  std::vector<std::pair<int, RGB>> direct;  // delta-only light of the large-step proposals
  int64_t mutations = 0, accepted = 0, large = 0, invalid = 0, b_count = 0;
  double b_sum = 0;
  RayCounts rays;
  std::map<std::string, double> failures;
};
using ChainResult = GdmltChainResult;

namespace {

// r's splats added to the per-pixel sums, each times `scale` (iterate: 1, into the accumulators;
// develop: the image's scale, into an open pass's image), and its large steps' delta-only light
// times `direct_scale` (with direct = "uniform"; else the splats carry it).
void add_chain_result(const ChainResult& r, int width, bool direct_uniform, double scale, double direct_scale,
                      double* primal, double* direct, double* gx, double* gy, double* density) {
  for (const Splat& s : r.splats) {
    const size_t p = static_cast<size_t>(s.pixel);
    const auto& g = s.sample;
    const double w = s.scale * scale;
    for (int c = 0; c < 3; ++c) {
      primal[3 * p + c] += g.primal[c] * w;
      if (!direct_uniform) direct[3 * p + c] += g.direct[c] * w;
      // Each forward difference from both of its pixels (their MIS weights sum to one).
      if (g.has[GradientPathTracer::kRight]) gx[3 * p + c] += g.diff[GradientPathTracer::kRight][c] * w;
      if (g.has[GradientPathTracer::kLeft]) gx[3 * (p - 1) + c] += g.diff[GradientPathTracer::kLeft][c] * w;
      if (g.has[GradientPathTracer::kDown]) gy[3 * p + c] += g.diff[GradientPathTracer::kDown][c] * w;
      if (g.has[GradientPathTracer::kUp]) gy[3 * (p - width) + c] += g.diff[GradientPathTracer::kUp][c] * w;
    }
  }
  for (int p : r.visits) density[p] += 1;
  for (const auto& [p, c] : r.direct)
    for (int k = 0; k < 3; ++k) direct[3 * static_cast<size_t>(p) + k] += c[k] * direct_scale;
}

}  // namespace

GradientDomainMlt::~GradientDomainMlt() = default;

// ---- Lazily mutated primary sample vector (pbrt-v3, MLTSampler::EnsureReady / Reject) ----

float PrimarySampleChain::uniform() {
  const size_t i = index_++;
  if (i >= x_.size()) x_.resize(i + 1);
  Coordinate& c = x_[i];
  c.backup = c.value;
  c.backup_modified = c.modified;
  if (large_step_) {
    c.value = rng_.uniform();
  } else {
    if (c.modified < last_large_step_) {  // never drawn, or an accepted large step since: uniform
      c.value = rng_.uniform();
      c.modified = last_large_step_;
      c.backup = c.value;
      c.backup_modified = c.modified;
    }
    // The n small steps this coordinate missed, at once: a Gaussian of deviation sigma sqrt(n)
    // (Box-Muller), wrapped onto [0, 1).
    const double n = static_cast<double>(iteration_ - c.modified);
    const double u1 = 1.0 - rng_.uniform(), u2 = rng_.uniform();
    const double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
    double v = c.value + z * sigma_ * std::sqrt(n);
    v -= std::floor(v);
    c.value = static_cast<float>(v) < 1.0f ? static_cast<float>(v) : 0.0f;
  }
  c.modified = iteration_;
  return c.value;
}

void PrimarySampleChain::reject() {
  for (Coordinate& c : x_)
    if (c.modified == iteration_) {
      c.value = c.backup;
      c.modified = c.backup_modified;
    }
  --iteration_;
}

GradientDomainMlt::GradientDomainMlt(const Scene& scene, const Params& params)
    : scene_(scene),
      gpt_(scene, params),
      mutations_(params.get<int>("mutations")),
      chain_count_(params.get<int>("chains")),
      bootstrap_per_pixel_(params.get<int>("bootstrap")),
      threads_(params.get<int>("threads")),
      large_step_(params.get<double>("large_step")),
      sigma_(params.get<double>("sigma")),
      alpha_(params.get<double>("primal_share")),
      large_step_mis_(params.get<bool>("large_step_mis")),
      seed_(params.get<uint64_t>("seed")),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()) {
  // Checked by the declarations (methods.cpp); primal_share > 0 keeps T > 0 wherever the primal
  // is non-zero (the estimator divides by T).
  recon_ = gradient_recon_options(params, threads_);
  direct_uniform_ = params.get<std::string>("direct") == "uniform";
  const size_t n = static_cast<size_t>(width_) * height_;
  primal_.assign(3 * n, 0.0);
  direct_.assign(3 * n, 0.0);
  gx_.assign(3 * n, 0.0);
  gy_.assign(3 * n, 0.0);
  density_.assign(n, 0.0);
}

double GradientDomainMlt::target(const GradientPathTracer::Sample& s) const {
  double t = alpha_ * abs_luminance(direct_uniform_ ? s.primal : s.primal + s.direct);
  for (const RGB& g : s.diff) t += abs_luminance(g);
  return t;
}

GradientDomainMlt::State GradientDomainMlt::evaluate(Sampler& sampler, RayCounts& rays,
                                                     std::map<std::string, double>* failures) const {
  // Film position over the whole image (the pixel is part of the state), then the lens.
  float fx = sampler.uniform() * width_, fy = sampler.uniform() * height_;
  fx = std::min(fx, std::nextafter(static_cast<float>(width_), 0.0f));
  fy = std::min(fy, std::nextafter(static_cast<float>(height_), 0.0f));
  const Vec2 lens(sampler.uniform(), sampler.uniform());
  // Motion blur: the shutter time is one more coordinate of the state (u4), drawn only when the
  // scene moves. Not one time per pass: the target T(u) would change under the chains between
  // passes, leaving each chain's current T and the bootstrap's b and start states those of
  // another time; as a coordinate, T is one fixed function over (u, t) whose integral spans the
  // shutter, large steps draw t uniformly and small steps move it as any other coordinate. The
  // base path and its four offsets share it (GradientPathTracer::trace, one thread).
  const float time = scene_.has_motion() ? sampler.uniform() : 0.0f;
  const ShutterTime at_time(time);
  State s;
  s.sample = gpt_.trace(Vec2(fx, fy), lens, sampler, rays, failures);
  s.pixel = static_cast<int>(fy) * width_ + static_cast<int>(fx);
  s.target = is_finite(s.sample) ? target(s.sample) : -1.0;  // < 0: invalid, never accepted
  return s;
}

bool GradientDomainMlt::bootstrap(ProgressSink* sink) {
  // ---- b from uniform samples, and start states in proportion to T ----
  const size_t n = static_cast<size_t>(bootstrap_per_pixel_) * width_ * height_;
  const size_t blocks = (n + kCancelPoll - 1) / kCancelPoll;
  if (!boot_) {
    boot_ = std::make_unique<OpenBootstrap>();
    boot_->t.assign(n, 0.0);
    boot_->direct.assign(n, {0, RGB(0.0f)});
    boot_->primal.assign(n, RGB(0.0f));
    boot_->done.assign(blocks, 0);
  }
  OpenBootstrap& boot = *boot_;
  std::vector<double>& t = boot.t;
  std::atomic<int64_t> closest{0}, shadow{0}, invalid{0};
  std::atomic<size_t> blocks_now{0}, samples_now{0};  // blocks and samples this call did
  std::atomic<bool> stopped{false}, paused{false};
  // Blocks in order, each one whole; a pause (asked between blocks, after one this call at
  // least, so that a caller pausing at once still moves on) leaves the rest for the next call.
  parallel_for(blocks, threads_, [&](size_t begin, size_t end) {
    RayCounts rays;
    for (size_t k = begin; k < end; ++k) {
      if (boot.done[k]) continue;  // done before a pause
      if (stopped || paused) break;
      if (sink && sink->cancelled()) {
        stopped = true;
        break;
      }
      if (sink && blocks_now.load() > 0 && sink->pause()) {
        paused = true;
        break;
      }
      for (size_t i = k * kCancelPoll; i < std::min(n, (k + 1) * kCancelPoll); ++i) {
        Rng rng = Rng::for_key(seed_, i, kBootstrapKey);
        RngSampler sampler(rng);
        const State st = evaluate(sampler, rays, nullptr);
        const double ti = st.target;
        if (ti < 0) ++invalid;
        t[i] = std::max(ti, 0.0);
        if (ti >= 0) {
          boot.direct[i] = {st.pixel, st.sample.direct};
          boot.primal[i] = st.sample.primal;
        }
      }
      boot.done[k] = 1;
      blocks_now.fetch_add(1);
      samples_now.fetch_add(std::min(n, (k + 1) * kCancelPoll) - k * kCancelPoll);
    }
    closest += rays.closest;
    shadow += rays.shadow;
  });
  if (stopped) {
    boot_.reset();
    return false;
  }
  boot.closest += closest;
  boot.shadow += shadow;
  boot.invalid += invalid;
  boot.samples_done += samples_now;
  if (paused) return false;
  const std::vector<std::pair<int, RGB>>& direct = boot.direct;
  std::vector<double> cdf(n);
  double sum = 0;
  for (size_t i = 0; i < n; ++i) cdf[i] = (sum += t[i]);
  b_sum_ = sum;
  b_count_ = static_cast<int64_t>(n);
  if (direct_uniform_) {  // the bootstrap samples are uniform: they estimate the direct light too
    for (const auto& [p, c] : direct)
      for (int k = 0; k < 3; ++k) direct_[3 * static_cast<size_t>(p) + k] += c[k];
    uniform_count_ = static_cast<int64_t>(n);
  }
  chains_.clear();
  chains_.reserve(chain_count_);
  RayCounts rays;
  for (int c = 0; c < chain_count_; ++c) {
    Rng pick = Rng::for_key(seed_, c, kStartKey);
    size_t idx = 0;
    if (sum > 0) {
      const double u = pick.uniform() * sum;
      idx = std::min<size_t>(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin(), n - 1);
      while (t[idx] <= 0 && idx > 0) --idx;  // guard against landing on a zero-width bin
    }
    // Re-creates bootstrap sample idx as the chain's state (its first, all-uniform evaluation
    // draws the same numbers), then gives the chain its own stream: chains that start from the
    // same sample do not stay identical.
    PrimarySampleChain sampler(Rng::for_key(seed_, idx, kBootstrapKey), sigma_, large_step_);
    State first = evaluate(sampler, rays, nullptr);
    sampler.accept();
    sampler.set_rng(Rng::for_key(seed_, c, kChainKey));
    chains_.push_back(Chain{std::move(sampler), std::move(first)});
  }
  stats_.paths += static_cast<int64_t>(n) + chain_count_;
  stats_.rays += boot.closest + boot.shadow + rays.closest + rays.shadow;
  stats_.shadow_rays += boot.shadow + rays.shadow;
  stats_.invalid_samples += boot.invalid;
  boot_.reset();
  started_ = true;
  return true;
}

void GradientDomainMlt::iterate(ProgressSink* sink) {
  const auto start = std::chrono::steady_clock::now();
  if (!started_ && !bootstrap(sink)) {
    if (boot_) stats_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return;
  }
  const int64_t total = static_cast<int64_t>(mutations_) * width_ * height_;
  if (!open_) {  // a new pass
    open_ = std::make_unique<OpenPass>();
    open_->results.resize(chain_count_);
    // Brightness estimate so far (bootstrap and earlier large steps): the large-step MIS weights
    // need T / b at splat time.
    open_->b_now = b_count_ && b_sum_ > 0 ? b_sum_ / b_count_ : 1.0;
  }
  std::vector<ChainResult>& results = open_->results;
  const double b_now = open_->b_now;
  std::atomic<bool> paused{false};
  parallel_for(static_cast<size_t>(chain_count_), threads_, [&](size_t begin, size_t end) {
    for (size_t c = begin; c < end; ++c) {
      if ((sink && sink->cancelled()) || paused) return;
      Chain& chain = chains_[c];
      ChainResult& r = results[c];
      const int64_t count = total / chain_count_ + (static_cast<int64_t>(c) < total % chain_count_ ? 1 : 0);
      if (r.mutations == 0) {
        r.splats.reserve(2 * count);
        r.visits.reserve(count);
      }
      // From where a pause left the chain (r.mutations: its mutations this pass so far).
      const int64_t resumed_at = r.mutations;
      for (int64_t k = resumed_at; k < count; ++k) {
        // A chain stopped early is merged as it is: develop() divides by the mutations done.
        if (k % kCancelPoll == kCancelPoll - 1 && sink) {
          if (sink->cancelled()) break;
          // The pass stays open: the next call goes on from here (after a mutation at least, so
          // that a caller pausing at once still moves on).
          if (paused || (k > resumed_at && sink->pause())) {
            paused = true;
            break;
          }
        }
        // ---- Propose: large step (uniform) or small step (perturbation) ----
        chain.sampler.start_iteration();
        const bool large = chain.sampler.large_step();
        State prop = evaluate(chain.sampler, r.rays, &r.failures);
        if (prop.target < 0) ++r.invalid;
        if (large) {  // a uniform sample: refines the brightness estimate b (and the direct light)
          r.b_sum += std::max(prop.target, 0.0);
          ++r.b_count;
          ++r.large;
          if (direct_uniform_ && prop.target >= 0 && !prop.sample.direct.is_black())
            r.direct.push_back({prop.pixel, prop.sample.direct});
        }
        // ---- Accept / reject, splatting both states by their expected weights ----
        const State& cur = chain.current;
        const double a = prop.target <= 0 ? 0.0 : cur.target <= 0 ? 1.0 : std::min(1.0, prop.target / cur.target);
        if (large_step_mis_) {
          // Kelemen et al. 2002: the Metropolis samples (density T / b per mutation) and the
          // large-step proposals (uniform, probability p_large) combined by the balance heuristic.
          const double lw = large ? 1.0 : 0.0;
          if (prop.target > 0 && a + lw > 0)
            r.splats.push_back({prop.pixel, (a + lw) / (prop.target / b_now + large_step_), prop.sample});
          if (a < 1 && cur.target > 0)
            r.splats.push_back({cur.pixel, (1 - a) / (cur.target / b_now + large_step_), cur.sample});
        } else {
          if (a > 0) r.splats.push_back({prop.pixel, a / prop.target, prop.sample});
          if (a < 1 && cur.target > 0) r.splats.push_back({cur.pixel, (1 - a) / cur.target, cur.sample});
        }
        if (a > 0 && chain.sampler.rng().uniform() < a) {
          chain.sampler.accept();
          chain.current = std::move(prop);
          ++r.accepted;
        } else {
          chain.sampler.reject();
        }
        r.visits.push_back(chain.current.pixel);
        ++r.mutations;
      }
    }
  });

  if (paused && !sink->cancelled()) {
    stats_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return;
  }

  // ---- Merge in chain order (independent of the thread count) ----
  RayCounts rays;
  for (const ChainResult& r : results) {
    add_chain_result(r, width_, direct_uniform_, 1.0, 1.0, primal_.data(), direct_.data(), gx_.data(), gy_.data(),
                     density_.data());
    if (direct_uniform_) uniform_count_ += r.b_count;
    mutations_done_ += r.mutations;
    accepted_ += r.accepted;
    large_steps_ += r.large;
    b_sum_ += r.b_sum;
    b_count_ += r.b_count;
    rays.closest += r.rays.closest;
    rays.shadow += r.rays.shadow;
    stats_.invalid_samples += r.invalid;
    stats_.paths += r.mutations;
    for (const auto& [k, v] : r.failures) stats_.extra[k] += v;
  }
  open_.reset();
  stats_.passes += 1;
  stats_.rays += rays.closest + rays.shadow;
  stats_.shadow_rays += rays.shadow;
  const double m = std::max<int64_t>(mutations_done_, 1);
  stats_.extra["acceptance rate"] = accepted_ / m;
  stats_.extra["large-step share"] = large_steps_ / m;
  stats_.extra["brightness b"] = b_count_ ? b_sum_ / b_count_ : 0.0;
  stats_.extra["chains"] = chain_count_;
  stats_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void GradientDomainMlt::develop(Film& film) const {
  if (film.width() != width_ || film.height() != height_) film = Film(width_, height_);
  const size_t n = static_cast<size_t>(width_) * height_;
  if (boot_) {
    // A paused bootstrap: its uniform samples so far as a plain Monte Carlo image over the whole
    // film (each sample's pixel uniform: n / samples done each), no reconstruction; the gradient
    // passes are its forward differences, the sample density nothing yet.
    std::vector<double> image(3 * n, 0.0);
    const OpenBootstrap& boot = *boot_;
    const double w = boot.samples_done ? static_cast<double>(n) / boot.samples_done : 0.0;
    for (size_t k = 0; k < boot.done.size(); ++k) {
      if (!boot.done[k]) continue;
      for (size_t i = k * kCancelPoll; i < std::min(boot.t.size(), (k + 1) * kCancelPoll); ++i) {
        const auto& [p, d] = boot.direct[i];
        const RGB c = boot.primal[i] + d;
        for (int ch = 0; ch < 3; ++ch) image[3 * static_cast<size_t>(p) + ch] += c[ch] * w;
      }
    }
    std::vector<double> dx, dy;
    forward_differences(image, width_, height_, 3, &dx, &dy);
    write_gradient_passes(film, 3 * n, [&](size_t k) { return std::array<double, 4>{image[k], image[k], dx[k], dy[k]}; });
    Pass& dens = film.add_pass(pass::kSampleDensity, 1);
    std::fill(dens.data.begin(), dens.data.end(), 0.0f);
    return;
  }
  // A paused pass's chains so far count with the passes before (OpenPass).
  int64_t mutations = mutations_done_, b_count = b_count_, uniform_count = uniform_count_;
  double b_sum = b_sum_;
  if (open_)
    for (const ChainResult& r : open_->results) {
      mutations += r.mutations;
      b_sum += r.b_sum;
      b_count += r.b_count;
      if (direct_uniform_) uniform_count += r.b_count;
    }
  // E_u[g / T] under the chain's law is (1 / b) E_uniform[g]; a pixel's value is its integral
  // over the film (area 1 / n of primary sample space) times n.
  const double b = b_count ? b_sum / b_count : 0.0;
  // With large-step MIS the splats already carry b (weights 1 / (T / b + p_large)).
  const double scale = mutations ? static_cast<double>(n) * (large_step_mis_ ? 1.0 : b) /
                                       static_cast<double>(mutations)
                                 : 0.0;
  // Direct light: a plain Monte Carlo estimate from the uniform samples (n / count each), or,
  // with direct = "chain", from the chains' splats like the rest.
  const double direct_scale = direct_uniform_ ? (uniform_count ? static_cast<double>(n) / uniform_count : 0.0) : scale;
  std::vector<double> primal(3 * n), direct(3 * n), gx(3 * n), gy(3 * n), density(density_);
  for (size_t k = 0; k < 3 * n; ++k) {
    primal[k] = primal_[k] * scale;
    direct[k] = direct_uniform_ ? (uniform_count ? direct_[k] * static_cast<double>(n) / uniform_count : 0.0)
                                : direct_[k] * scale;  // direct_scale, rounded as before
    gx[k] = gx_[k] * scale;
    gy[k] = gy_[k] * scale;
  }
  if (open_)
    for (const ChainResult& r : open_->results)
      add_chain_result(r, width_, direct_uniform_, scale, direct_scale, primal.data(), direct.data(), gx.data(),
                       gy.data(), density.data());
  develop_gradient_passes(film, primal, gx, gy, direct, width_, height_, recon_);
  Pass& dens = film.add_pass(pass::kSampleDensity, 1);
  for (size_t i = 0; i < n; ++i) dens.data[i] = static_cast<float>(density[i]);
}

}  // namespace gp
