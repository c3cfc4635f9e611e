#include "distributed/merge.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "integrators/gradient/gradient_passes.h"
#include "integrators/methods.h"
#include "io/exr.h"

namespace gp {

namespace {

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
  throw std::runtime_error(fmt::format("cannot merge '{}': {}", path, why));
}


// The core's pass a film pass is: its own name, or Blender's "<view layer>.<label>".
std::string_view canonical(const std::string& name) {
  for (const pass::Info& p : pass::kAll) {
    if (name == p.name) return p.name;
    const std::string suffix = "." + std::string(p.label);
    if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
      return p.name;
  }
  return name;
}

// The film pass that is core pass `which`, or nullptr.
const std::string* find_pass(const Film& film, std::string_view which) {
  for (const auto& [name, p] : film.passes())
    if (canonical(name) == which) return &name;
  return nullptr;
}

void check_compatible(const MergeInput& first, const MergeInput& in) {
  const RunInfo &a = first.run, &b = in.run;
  if (b.method != a.method)
    refuse(in.path, fmt::format("method '{}' but '{}' used '{}'", b.method, first.path, a.method));
  if (b.scene_hash != a.scene_hash)
    refuse(in.path, fmt::format("rendered another scene ('{}', fingerprint {}) than '{}' ('{}', fingerprint {})",
                                b.scene, b.scene_hash, first.path, a.scene, a.scene_hash));
  if (b.width != a.width || b.height != a.height || in.film.width() != first.film.width() ||
      in.film.height() != first.film.height())
    refuse(in.path, fmt::format("image is {}x{} but '{}' is {}x{}", in.film.width(), in.film.height(), first.path,
                                first.film.width(), first.film.height()));
  if (b.params != a.params) {
    std::string diff;
    for (const auto& [k, v] : a.params.items())
      if (!b.params.contains(k) || b.params[k] != v)
        diff += fmt::format(" {}={} (here {})", k, v.dump(), b.params.contains(k) ? b.params[k].dump() : "unset");
    for (const auto& [k, v] : b.params.items())
      if (!a.params.contains(k)) diff += fmt::format(" {} unset (here {})", k, v.dump());
    refuse(in.path, fmt::format("method parameters differ from '{}':{}", first.path, diff));
  }
  for (const auto& [name, p] : first.film.passes())
    if (!in.film.has_pass(name) || in.film.pass(name).channels != p.channels)
      refuse(in.path, fmt::format("has no pass '{}' with {} channels, which '{}' has", name, p.channels, first.path));
  if (in.film.passes().size() != first.film.passes().size())
    refuse(in.path, fmt::format("has other passes than '{}'", first.path));
}

}  // namespace

bool merge_keeps_bias(const std::string& method) {
  const Method* m = lookup_method(method);
  return m && m->merge.keeps_bias;
}

MergeResult merge_files(const std::vector<std::string>& paths, int threads) {
  std::vector<MergeInput> runs;
  for (const std::string& path : paths) {
    MergeInput in;
    in.path = path;
    in.run = from_attributes(read_exr_attributes(path), path);
    in.film = read_exr(path);
    runs.push_back(std::move(in));
  }
  return merge_runs(runs, threads);
}

MergeResult merge_runs(const std::vector<MergeInput>& runs, int threads) {
  if (runs.empty()) throw std::runtime_error("nothing to merge: no input files");
  const MergeInput& first = runs.front();
  const std::string& method = first.run.method;
  const Method* rule = lookup_method(method);
  if (!rule) refuse(first.path, fmt::format("unknown method '{}'", method));
  std::map<uint64_t, std::string> seen;  // seed -> file
  double total = 0;
  for (const MergeInput& in : runs) {
    check_compatible(first, in);
    if (in.run.paths <= 0) refuse(in.path, "the run did no work (gradphoton.paths is 0)");
    for (uint64_t s : in.run.seeds)
      if (auto [it, fresh] = seen.emplace(s, in.path); !fresh)
        refuse(in.path, fmt::format("seed {} was already used by '{}': runs must have different seeds to be independent",
                                    s, it->second));
    total += static_cast<double>(in.run.paths);
  }

  MergeResult out;
  out.run = first.run;
  out.run.seeds.clear();
  out.run.runs = out.run.passes = out.run.paths = 0;
  out.run.seconds = 0;
  for (const MergeInput& in : runs) {
    out.run.seeds.insert(out.run.seeds.end(), in.run.seeds.begin(), in.run.seeds.end());
    out.run.runs += in.run.runs;
    out.run.passes += in.run.passes;
    out.run.paths += in.run.paths;
    out.run.seconds += in.run.seconds;
    if (in.run.version != first.run.version)
      out.warnings.push_back(fmt::format("'{}' was written by gradphoton {}, '{}' by {}", in.path, in.run.version,
                                         first.path, first.run.version));
  }

  const int W = first.film.width(), H = first.film.height();
  const size_t n = first.film.pixel_count();
  out.film = Film(W, H);
  const std::string* combined_name = find_pass(first.film, pass::kCombined);
  const bool biased = rule->merge.keeps_bias;
  for (const auto& [name, proto] : first.film.passes()) {
    const std::string_view kind = canonical(name);
    if (kind == pass::kError) continue;  // after `combined`, below
    std::vector<double> acc(proto.data.size(), 0.0);
    for (const MergeInput& in : runs) {
      const double w = static_cast<double>(in.run.paths) / total;
      const std::vector<float>& d = in.film.pass(name).data;
      for (size_t k = 0; k < acc.size(); ++k) {
        const double v = d[k];
        if (kind == pass::kPhotonCount || kind == pass::kSampleDensity) acc[k] += v;
        else if (kind == pass::kSpectralGradient) acc[k] += w * v * v;
        else acc[k] += w * v;
      }
    }
    Pass& p = out.film.add_pass(name, proto.channels);
    for (size_t k = 0; k < acc.size(); ++k)
      p.data[k] = static_cast<float>(kind == pass::kSpectralGradient ? std::sqrt(acc[k]) : acc[k]);
  }

  if (rule->merge.reconstructs) {
    // Reconstruct once from the merged primal and gradients, as the method does, plus what each
    // run's `combined` holds beyond the reconstruction of its own passes, weighted as the passes:
    // the part the method adds after its solve (emission kept out of the gradients, which an L1
    // solve of the passes does not give back exactly; GPM's emission from its further camera
    // paths, which `primal` leaves out). So a merge of one run is that run.
    const std::string* primal = find_pass(out.film, pass::kPrimal);
    const std::string* gx = find_pass(out.film, pass::kGradientX);
    const std::string* gy = find_pass(out.film, pass::kGradientY);
    if (!primal || !gx || !gy || !combined_name)
      refuse(first.path, fmt::format("a {} run needs its combined, primal, gradient_x and gradient_y passes to be "
                                     "merged (in Blender: enable them under View Layer > Passes)", method));
    const Method& m = find_method(method);
    const ReconOptions recon = gradient_recon_options(Params(first.run.params).bound(m.name, m.params), threads);
    const Pass& P = out.film.pass(*primal);
    const int c = P.channels;
    Pass& comb = out.film.pass(*combined_name);
    const int cc = std::min(c, comb.channels);
    auto reconstruct = [&](const Film& f) {
      return screened_poisson(f.pass(*primal).data, f.pass(*gx).data, f.pass(*gy).data, W, H, c, recon);
    };
    std::vector<double> after_solve(n * c, 0.0);
    for (const MergeInput& in : runs) {
      const double w = static_cast<double>(in.run.paths) / total;
      const std::vector<float> own = reconstruct(in.film);
      const Pass& run_comb = in.film.pass(*combined_name);
      for (size_t i = 0; i < n; ++i)
        for (int k = 0; k < cc; ++k)
          after_solve[i * c + k] += w * (double(run_comb.data[i * run_comb.channels + k]) - own[i * c + k]);
    }
    const std::vector<float> rec = reconstruct(out.film);
    for (size_t i = 0; i < n; ++i)
      for (int k = 0; k < cc; ++k)
        comb.data[i * comb.channels + k] = static_cast<float>(rec[i * c + k] + after_solve[i * c + k]);
  }

  if (const std::string* err = find_pass(first.film, pass::kError)) {
    if (!combined_name || first.film.pass(*combined_name).channels < 3)
      refuse(first.path, "an error pass needs an RGB combined pass to be merged");
    auto luminance = [&](const Film& f, size_t i) {
      const float* p = &f.pass(*combined_name).data[i * f.pass(*combined_name).channels];
      return RGB(p[0], p[1], p[2]).luminance();
    };
    Pass& e = out.film.add_pass(*err, 1);
    for (size_t i = 0; i < n; ++i) {
      double abs_err = 0;
      for (const MergeInput& in : runs) {
        const double w = static_cast<double>(in.run.paths) / total;
        const double a = in.film.pass(*err).data[i] * std::max(0.0f, luminance(in.film, i));
        abs_err += biased ? w * a : (w * a) * (w * a);
      }
      const double L = luminance(out.film, i);
      e.data[i] = L > 0 ? static_cast<float>(biased ? abs_err / L : std::sqrt(abs_err) / L) : 0.0f;
    }
  }
  return out;
}

}  // namespace gp
