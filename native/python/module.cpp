// pybind11 module gradphoton._native: the core as the addon and scripts see it. pybind11
// types stay in this file; native work releases the GIL so Blender's UI stays responsive.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "core/film.h"
#include "distributed/run_info.h"
#include "integrators/aov.h"
#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "integrators/photon/progressive_photon.h"
#include "io/exr.h"
#include "media/vdb_file.h"
#include "reconstruction/poisson.h"
#include "scene/builder.h"
#include "scene/loader.h"
#include "session/render_session.h"

namespace py = pybind11;
using namespace gp;

namespace {

// A numpy copy of a contiguous native array.
template <typename T>
py::array_t<T> to_array(const T* data, std::vector<size_t> shape) {
  py::array_t<T> a(shape);
  size_t n = 1;
  for (size_t d : shape) n *= d;
  if (n) std::copy(data, data + n, a.mutable_data());
  return a;
}

// Python dict -> Params, through JSON text (values are plain numbers, strings and lists).
Params params_from_dict(const py::dict& d) {
  py::object dumps = py::module_::import("json").attr("dumps");
  return Params(nlohmann::json::parse(dumps(d).cast<std::string>()));
}

py::object to_python(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// One method's parameter declarations (methods.h), in declaration order: what the addon's
// properties and panels, the docs table and the tests are made from.
py::list method_params(const std::string& method) {
  py::list out;
  for (const ParamDecl& d : find_method(method).params) {
    py::dict p;
    p["name"] = d.name;
    p["type"] = to_string(d.type);
    p["default"] = to_python(d.default_value);
    p["min"] = std::isfinite(d.min) ? py::object(py::float_(d.min)) : py::none();
    p["max"] = std::isfinite(d.max) ? py::object(py::float_(d.max)) : py::none();
    p["min_open"] = d.min_open;
    p["max_open"] = d.max_open;
    p["choices"] = d.choices;
    p["range"] = d.range_text();
    p["label"] = d.label;
    p["description"] = d.description;
    p["symbol"] = d.symbol;
    p["reference"] = d.reference;
    p["zero_means"] = d.zero_means;
    p["manual_value"] = to_python(d.manual_value);
    p["read_when"] = d.read_when;
    p["shared"] = d.shared;
    p["group"] = d.group;
    out.append(p);
  }
  return out;
}

// Row-major (K, 4, 4) float array -> transforms.
std::vector<Transform> transforms_from_array(const py::object& obj, const std::string& object) {
  std::vector<Transform> out;
  if (obj.is_none()) return out;
  auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || !(a.ndim() == 3 || a.ndim() == 2) || a.shape(a.ndim() - 1) != 4 || a.shape(a.ndim() - 2) != 4)
    throw py::value_error("object '" + object + "': matrices must be a (4, 4) or (K, 4, 4) array");
  const size_t k = a.ndim() == 3 ? a.shape(0) : 1;
  out.resize(k);
  const float* d = a.data();
  for (size_t i = 0; i < k; ++i)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) out[i].m[r][c] = d[16 * i + 4 * r + c];
  return out;
}

// Checks dtype, layout and shape without converting: a silent conversion of a million-vertex
// array would hide a slow path, so the wrong dtype is an error that says which one to use.
template <typename T>
py::array_t<T> exact_array(const py::object& obj, const std::string& object, const char* what, int columns,
                           const char* dtype) {
  const std::string prefix = "object '" + object + "': " + what;
  if (!py::isinstance<py::array_t<T>>(obj))
    throw py::type_error(prefix + " must be a numpy " + dtype + " array, not " + py::str(py::type::of(obj)).cast<std::string>() +
                         (py::isinstance<py::array>(obj) ? " of " + py::str(obj.attr("dtype")).cast<std::string>() : ""));
  py::array_t<T> a = obj.cast<py::array_t<T>>();
  if (!(a.flags() & py::array::c_style)) throw py::type_error(prefix + " must be C-contiguous (numpy.ascontiguousarray)");
  const bool ok = columns == 1 ? (a.ndim() == 1) : (a.ndim() == 2 && a.shape(1) == columns) || (a.ndim() == 1 && a.shape(0) % columns == 0);
  if (!ok) {
    std::string shape;
    for (py::ssize_t d = 0; d < a.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(a.shape(d));
    throw py::value_error(prefix + " must have shape (N, " + std::to_string(columns) + "), not (" + shape + ")");
  }
  return a;
}

// The Python session's sink: cancel() from any thread, and a pause at a deadline that
// iterate(seconds) sets (ProgressSink::pause: only methods with tile-resumable passes ask).
class SessionSink : public ProgressSink {
 public:
  void pause_after(double seconds) {
    using clock = std::chrono::steady_clock;
    deadline_ = seconds > 0 ? (clock::now() + std::chrono::duration_cast<clock::duration>(
                                                  std::chrono::duration<double>(seconds)))
                                  .time_since_epoch()
                                  .count()
                            : 0;
  }
  bool pause() override {
    const auto d = deadline_.load(std::memory_order_relaxed);
    return d != 0 && std::chrono::steady_clock::now().time_since_epoch().count() >= d;
  }

 private:
  std::atomic<std::chrono::steady_clock::rep> deadline_{0};
};

// add_mesh's attributes: [(name, domain "point" | "corner" | "face", float32 (N,) or (N, k)
// with k 1-4)], and the render colour attribute's name (None or "": none). Sizes are checked
// against the mesh when the scene is finalized.
std::shared_ptr<const shading::MeshAttributes> attributes_from_list(const py::object& list, const py::object& default_color,
                                                                    const std::string& object) {
  if (list.is_none()) return nullptr;
  auto out = std::make_shared<shading::MeshAttributes>();
  const std::string want = default_color.is_none() ? std::string() : default_color.cast<std::string>();
  for (const py::handle item : list) {
    const py::tuple t = py::reinterpret_borrow<py::object>(item).cast<py::tuple>();
    if (t.size() != 3) throw py::value_error("object '" + object + "': attributes are (name, domain, values) tuples");
    shading::MeshAttribute a;
    a.name = t[0].cast<std::string>();
    const std::string domain = t[1].cast<std::string>();
    if (domain == "point") a.domain = shading::AttributeDomain::Point;
    else if (domain == "corner") a.domain = shading::AttributeDomain::Corner;
    else if (domain == "face") a.domain = shading::AttributeDomain::Face;
    else throw py::value_error("object '" + object + "': attribute '" + a.name + "': unknown domain '" + domain + "'");
    const py::object values = py::reinterpret_borrow<py::object>(t[2]);
    const std::string what = "attribute '" + a.name + "'";
    if (!py::isinstance<py::array_t<float>>(values))
      throw py::type_error("object '" + object + "': " + what + " must be a numpy float32 array");
    const py::array_t<float> arr = values.cast<py::array_t<float>>();
    const int k = arr.ndim() == 1 ? 1 : arr.ndim() == 2 ? static_cast<int>(arr.shape(1)) : 0;
    if (k < 1 || k > 4)
      throw py::value_error("object '" + object + "': " + what + " must have shape (N,) or (N, k) with k 1 to 4");
    const py::array_t<float> a2 = exact_array<float>(values, object, what.c_str(), k, "float32");
    a.components = static_cast<uint8_t>(k);
    a.values.assign(a2.data(), a2.data() + a2.size());
    if (!want.empty() && a.name == want) out->default_color = static_cast<int>(out->list.size());
    out->list.push_back(std::move(a));
  }
  return out;
}

// One progressive render (session/render_session.h), with the GIL released while it works.
class Session {
 public:
  Session(std::shared_ptr<Scene> scene, const std::string& method, const py::dict& params)
      : session_(std::move(scene), method, params_from_dict(params)) {}
  // One pass of the method, and while they are few, one of the auxiliary passes (aov.h).
  // With seconds > 0, a method whose pass can pause at a tile (pt, spt, spt-hero) returns after
  // about that long with the pass unfinished; the next call goes on with it.
  void iterate(double seconds) {
    py::gil_scoped_release release;
    sink_.pause_after(seconds);
    session_.iterate(&sink_);
    sink_.pause_after(0);
  }
  void run(double seconds, int64_t passes) {
    py::gil_scoped_release release;
    session_.run(StopRule{seconds, passes, 0}, &sink_);
  }
  // The auxiliary passes (aov.h) are made unless switched off (Blender: when none is enabled).
  void set_aux_passes(bool on) { session_.set_aux_passes(on); }
  void cancel() { sink_.cancel_flag = true; }
  bool cancelled() { return sink_.cancel_flag; }
  // Every pass as a float32 array of shape (height, width, channels), row 0 at the top.
  py::dict develop(bool display) {
    Film film;
    {
      py::gil_scoped_release release;
      film = session_.develop(display);
    }
    py::dict out;
    for (const auto& [name, p] : film.passes()) {
      py::array_t<float> a({film.height(), film.width(), p.channels});
      std::copy(p.data.begin(), p.data.end(), a.mutable_data());
      out[py::str(name)] = a;
    }
    return out;
  }
  void write_exr_file(const std::string& path) {
    py::gil_scoped_release release;
    session_.write_exr(path);
  }
  // The run's record for EXR headers (distributed/run_info.h): {"gradphoton.method": ..., ...}.
  std::map<std::string, std::string> run_info() const { return session_.run_record(); }
  py::dict stats() const {
    const Stats& s = session_.stats();
    py::dict d;
    d["passes"] = s.passes;
    d["paths"] = s.paths;
    d["rays"] = s.rays;
    d["invalid_samples"] = s.invalid_samples;
    d["seconds"] = s.seconds;
    for (const auto& [k, v] : s.extra) d[py::str(k)] = v;
    return d;
  }
  const std::vector<std::string>& unused() const { return session_.unused(); }
  bool stale() const { return session_.stale(); }
  const std::vector<std::string>& unused_report() const { return session_.unused_report(); }
  const std::vector<std::string>& feature_report() const { return session_.feature_report(); }
  std::vector<std::string> stop_report(double seconds, int64_t passes, double target_error) const {
    return session_.stop_report(StopRule{seconds, passes, target_error});
  }
  const std::vector<std::string>& passes() const { return session_.passes(); }
  std::string method() const { return session_.integrator().name(); }
  double estimated_error() const { return session_.integrator().estimated_error(); }
  // The terms of every pixel's error bound (ProgressivePhotonMapping::ErrorTerms), as
  // {name: float64 array (H, W)}: what scripts/calibration.py decomposes the coverage with.
  py::dict error_terms() const {
    const auto* ppm = dynamic_cast<const ProgressivePhotonMapping*>(&session_.integrator());
    if (!ppm) throw std::invalid_argument("error_terms: method '" + method() + "' has no photon error estimate");
    const Camera& camera = session_.scene().camera;
    const int w = camera.film_width(), h = camera.film_height();
    const char* names[] = {"radiance", "bias", "bias_sd", "noise_sd", "sigma", "bound", "mean_abs", "photon_passes", "radius", "cut", "edge_bias", "edge_bias_sd"};
    constexpr int kTerms = std::size(names);
    std::vector<py::array_t<double>> arrays;
    for (int k = 0; k < kTerms; ++k) arrays.emplace_back(std::vector<py::ssize_t>{h, w});
    for (size_t i = 0; i < static_cast<size_t>(w) * h; ++i) {
      const auto e = ppm->error_terms(i);
      const double v[] = {e.radiance, e.bias, e.bias_sd, e.noise_sd, e.sigma, e.bound, e.mean_abs, e.photon_passes, e.radius, e.cut, e.edge_bias, e.edge_bias_sd};
      static_assert(std::size(v) == kTerms);
      for (int k = 0; k < kTerms; ++k) arrays[k].mutable_data()[i] = v[k];
    }
    py::dict out;
    for (int k = 0; k < kTerms; ++k) out[names[k]] = arrays[k];
    return out;
  }

 private:
  RenderSession session_;
  SessionSink sink_;
};

// Scene.width / .height: a new image size drops any crop window (it was in pixels of the old size).
void resize_image(Scene& s, int width, int height) {
  Scene::UpdateGuard guard(s);
  Camera c = s.camera;
  c.width = width;
  c.height = height;
  c.crop_width = c.crop_height = c.crop_x = c.crop_y = 0;
  s.set_camera(c);
}

// What a method is, as it declares itself (integrators/methods.h): label, passes, error
// estimate, merge rule, statistics, supported scene features.
py::dict method_description(const std::string& name) {
  const Method& m = find_method(name);
  py::dict d;
  d["name"] = m.name;
  d["label"] = m.label;
  d["summary"] = m.summary;
  d["tooltip"] = m.tooltip;
  py::list passes;
  for (const PassDecl& p : m.passes) passes.append(py::make_tuple(std::string(p.name), p.when_param, p.or_holdout));
  d["passes"] = passes;
  d["error_estimate"] = m.error_estimate;
  d["merge"] = py::dict(py::arg("keeps_bias") = m.merge.keeps_bias, py::arg("reconstructs") = m.merge.reconstructs);
  py::list stats;
  for (const StatDecl& st : m.stats) stats.append(py::make_tuple(st.key, st.label, st.format));
  d["stats"] = stats;
  d["supports"] = py::dict(py::arg("media") = m.supports.media, py::arg("motion_blur") = m.supports.motion_blur,
                           py::arg("grid_media") = m.supports.grid_media,
                           py::arg("environment_map") = m.supports.environment_map,
                           py::arg("caustics") = m.supports.caustics);
  d["lobe_visibility"] = py::dict(py::arg("surfaces") = m.lobe_visibility.surfaces,
                                  py::arg("lights") = m.lobe_visibility.lights);
  d["per_pixel"] = m.per_pixel;
  d["paused_pass_covers_image"] = m.paused_pass_covers_image;
  return d;
}

// What a method writes with `params`, from its declaration (no probe render): the passes its
// develop() writes, plus the auxiliary ones every session adds; whether it estimates its error;
// which of `params` it does not declare.
py::dict method_info(const std::string& method, const py::dict& params) {
  const Method& m = find_method(method);
  const Params given = params_from_dict(params);
  const Params bound = given.bound(m.name, m.params);
  std::vector<std::string> passes = m.passes_with(bound);
  for (auto aux : {pass::kAlbedo, pass::kNormal, pass::kDepth}) passes.emplace_back(aux);
  std::vector<std::string> unused;
  for (const auto& [k, v] : given.json().items())
    if (!m.find(k)) unused.push_back(k);
  py::dict out;
  out["passes"] = passes;
  out["error_estimate"] = m.error_estimate;
  out["unused"] = unused;
  out["lobe_visibility"] = py::dict(py::arg("surfaces") = m.lobe_visibility.surfaces,
                                    py::arg("lights") = m.lobe_visibility.lights);
  out["holdout"] = m.holdout;
  return out;
}

// The methods as they declare themselves (integrators/methods.h).
void bind_methods(py::module_& m) {
  m.attr("PASS_COMBINED") = std::string(pass::kCombined);
  m.def("methods", &integrator_names, "Names of the rendering methods");
  m.def("passes", []() {
    py::list out;
    for (const pass::Info& p : pass::kAll)
      out.append(py::make_tuple(std::string(p.name), p.channels, std::string(p.label)));
    return out;
  }, "Every pass any method may produce: [(name, channels, label)] (film.h pass::kAll)");
  m.def("method_params", &method_params, py::arg("method"),
        "The method's parameters as it declares them (integrators/methods.cpp), in order: [{'name', 'type' "
        "(int|float|bool|string), 'default', 'min', 'max' (None: unbounded), 'min_open', 'max_open', 'choices', "
        "'range' (text), 'label', 'description', 'symbol', 'reference', 'zero_means' (0 = automatic: what it "
        "does), 'manual_value', 'read_when', 'shared' (one value for every method), 'group' (panel)}]");
  m.def("method_summary", [](const std::string& method) { return find_method(method).summary; }, py::arg("method"),
        "One line on what the method computes and its paper");
  m.def("method_description", &method_description, py::arg("method"),
        "The method as it declares itself: {'name', 'label', 'summary', 'tooltip', 'passes': [(name, "
        "when_param, or_holdout: also on a scene that holds out)], 'error_estimate', 'merge': {'keeps_bias', 'reconstructs'}, 'stats': [(key, label, "
        "format)] (a key with '*' sums the keys it matches), 'supports': {'media', 'motion_blur', 'grid_media', "
        "'environment_map', 'caustics'}, 'lobe_visibility', 'per_pixel', 'paused_pass_covers_image' (a pass paused part-way "
        "develops to an image of every pixel)}");
  m.def("method_info", &method_info, py::arg("method"), py::arg("params") = py::dict(),
        "What a method writes with these params, from its declaration: {'passes': names its develop() writes, "
        "'error_estimate': whether it estimates its error (target-error stop), 'unused': params it does not read, "
        "'lobe_visibility': {'surfaces': bool, 'lights': bool}, the per-kind ray visibility switches it honours, "
        "'holdout': whether camera rays end at holdout surfaces with no colour and alpha 0}");
}

// Images: EXR read and write, screened Poisson reconstruction.
void bind_images(py::module_& m) {
  // ---- OpenVDB grids (media/vdb_file.h): what the exporter needs of a Volume object's file,
  // and a writer for tests (Debian's Blender has no pyopenvdb) ----
  m.def("vdb_grids", [](const std::string& path) {
    py::list out;
    for (const VdbGridInfo& info : vdb_grid_names(path)) {
      std::shared_ptr<VoxelGrid> g;
      try {
        g = read_vdb_grid(path, info.name);
      } catch (const VdbError&) {
        continue;  // a grid of a type media do not read (bool, int, points): not listed
      }
      py::array_t<float> m({4, 4});
      auto r = m.mutable_unchecked<2>();
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) r(i, j) = i < 3 ? g->index_to_object.m[i][j] : (j == 3 ? 1.0f : 0.0f);
      out.append(py::dict(py::arg("name") = info.name, py::arg("channels") = g->channels, py::arg("lo") = g->lo,
                          py::arg("size") = g->size, py::arg("index_to_object") = m));
    }
    return out;
  }, py::arg("path"),
        "The float and vector grids of an OpenVDB file: [{'name', 'channels', 'lo', 'size' (the active "
        "voxels' box in index space), 'index_to_object' (4x4)}]; VdbError (a ValueError) naming the file");
  m.def("write_vdb", [](const std::string& path, const py::list& grids) {
    std::vector<VoxelGrid> gs;
    for (const py::handle& h : grids) {
      const py::dict d = py::reinterpret_borrow<py::dict>(h);
      VoxelGrid g;
      g.name = d["name"].cast<std::string>();
      const auto v = d["values"].cast<py::array_t<float, py::array::c_style | py::array::forcecast>>();
      if (v.ndim() != 3 && v.ndim() != 4) throw std::invalid_argument("values: (nz, ny, nx) or (nz, ny, nx, 3)");
      g.channels = v.ndim() == 4 ? static_cast<int>(v.shape(3)) : 1;
      if (g.channels != 1 && g.channels != 3) throw std::invalid_argument("values: 1 or 3 channels");
      g.size = {static_cast<int>(v.shape(2)), static_cast<int>(v.shape(1)), static_cast<int>(v.shape(0))};
      g.data.assign(v.data(), v.data() + v.size());
      if (d.contains("lo")) g.lo = d["lo"].cast<std::array<int, 3>>();
      if (d.contains("background")) {
        const float b = d["background"].cast<float>();
        g.background = {b, b, b};
      }
      if (d.contains("index_to_object")) {
        const auto m = d["index_to_object"].cast<py::array_t<float, py::array::c_style | py::array::forcecast>>();
        if (m.ndim() != 2 || m.shape(0) != 4 || m.shape(1) != 4) throw std::invalid_argument("index_to_object: 4x4");
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 4; ++j) g.index_to_object.m[i][j] = m.at(i, j);
      }
      gs.push_back(std::move(g));
    }
    std::vector<const VoxelGrid*> ptrs;
    for (const VoxelGrid& g : gs) ptrs.push_back(&g);
    write_vdb(path, ptrs);
  }, py::arg("path"), py::arg("grids"),
        "Writes grids [{'name', 'values' (nz, ny, nx[, 3]) float, 'lo' (i, j, k), 'background', "
        "'index_to_object' 4x4}] to an OpenVDB file (tests and tools)");
  m.def("read_exr", [](const std::string& path) {
    Film film;
    {
      py::gil_scoped_release release;
      film = read_exr(path);
    }
    py::dict out;
    for (const auto& [name, p] : film.passes()) {
      py::array_t<float> a({film.height(), film.width(), p.channels});
      std::copy(p.data.begin(), p.data.end(), a.mutable_data());
      out[py::str(name)] = a;
    }
    return out;
  }, py::arg("path"), "Read an EXR: {pass name: float32 array (H, W, C)}, row 0 at the top");

  m.def("read_exr_metadata", [](const std::string& path) {
    py::gil_scoped_release release;
    return read_exr_attributes(path);
  }, py::arg("path"), "The string attributes of an EXR's header, e.g. the run record {'gradphoton.method': ...}");

  m.def("write_exr", [](const std::string& path, const py::dict& passes,
                        const std::map<std::string, std::string>& metadata) {
    Film film;
    for (const auto& [key, value] : passes) {
      if (!py::isinstance<py::array_t<float>>(value)) throw py::type_error("passes must be numpy float32 arrays");
      auto a = value.cast<py::array_t<float, py::array::c_style | py::array::forcecast>>();
      if (a.ndim() != 3 || (a.shape(2) != 1 && a.shape(2) != 3))
        throw py::value_error("passes must have shape (H, W, 1) or (H, W, 3)");
      if (film.width() == 0) film = Film(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)));
      if (a.shape(0) != film.height() || a.shape(1) != film.width())
        throw py::value_error("all passes must have the same height and width");
      Pass& p = film.add_pass(key.cast<std::string>(), static_cast<int>(a.shape(2)));
      std::copy(a.data(), a.data() + a.size(), p.data.begin());
    }
    py::gil_scoped_release release;
    write_exr(path, film, metadata);
  }, py::arg("path"), py::arg("passes"), py::arg("metadata") = std::map<std::string, std::string>{},
     "Write {pass name: float32 array (H, W, C)} as a multi-layer EXR, `metadata` as string header attributes");
  m.def("reconstruct", [](const py::object& primal, const py::object& gx, const py::object& gy, double lam,
                          const std::string& method, int threads) {
    auto check = [](const py::object& obj, const char* what) {
      if (!py::isinstance<py::array_t<float>>(obj)) throw py::type_error(std::string(what) + " must be a numpy float32 array");
      auto a = obj.cast<py::array_t<float, py::array::c_style | py::array::forcecast>>();
      if (a.ndim() != 3) throw py::value_error(std::string(what) + " must have shape (H, W, C)");
      return a;
    };
    auto p = check(primal, "primal"), x = check(gx, "gx"), y = check(gy, "gy");
    for (int d = 0; d < 3; ++d)
      if (x.shape(d) != p.shape(d) || y.shape(d) != p.shape(d))
        throw py::value_error("primal, gx and gy must have the same shape");
    const int h = static_cast<int>(p.shape(0)), w = static_cast<int>(p.shape(1)), c = static_cast<int>(p.shape(2));
    ReconOptions o;
    try {
      o.norm = parse_recon_norm(method);
    } catch (const std::invalid_argument& e) {
      throw py::value_error(e.what());
    }
    o.lambda = lam;
    o.threads = threads;
    if (!(lam > 0)) throw py::value_error("lam must be > 0");
    std::vector<float> vp(p.data(), p.data() + p.size()), vx(x.data(), x.data() + x.size()),
        vy(y.data(), y.data() + y.size()), r;
    {
      py::gil_scoped_release release;
      r = screened_poisson(vp, vx, vy, w, h, c, o);
    }
    py::array_t<float> out({h, w, c});
    std::copy(r.begin(), r.end(), out.mutable_data());
    return out;
  }, py::arg("primal"), py::arg("gx"), py::arg("gy"), py::arg("lam") = 0.2, py::arg("method") = "l2",
     py::arg("threads") = 0,
     "Screened Poisson reconstruction (gradient-domain photon paper eq. 3) of float32 (H, W, C) arrays: "
     "gx[y, x] = I[y, x+1] - I[y, x], gy[y, x] = I[y+1, x] - I[y, x]; method 'l2' (exact, DCT) or 'l1' (IRLS)");

}

// Scenes: loaded from files, read back, updated in place (the rendered viewport).
void bind_scene(py::module_& m) {
  py::class_<Scene, std::shared_ptr<Scene>>(m, "Scene")
      .def_property_readonly("triangle_count", &Scene::triangle_count)
      .def_property_readonly("light_count", [](const Scene& s) { return s.light_set().lights().size(); })
      .def_property_readonly("material_names", [](const Scene& s) {
        std::vector<std::string> n;
        for (const auto& m : s.materials) n.push_back(m.name);
        return n;
      })
      .def_property_readonly("warnings", [](const Scene& s) { return s.warnings.summary(); })
      // Setting the size drops a crop window (it was in pixels of the old size).
      .def_property("width", [](const Scene& s) { return s.camera.width; },
                    [](Scene& s, int w) { resize_image(s, w, s.camera.height); })
      .def_property("height", [](const Scene& s) { return s.camera.height; },
                    [](Scene& s, int h) { resize_image(s, s.camera.width, h); })
      // ---- Read-only views for importers (scripts/json_to_blend.py): the loaded, tessellated scene
      .def("meshes", [](const Scene& s) {
        py::list out;
        for (const Mesh& m : s.meshes) {
          py::dict d;
          d["name"] = m.name;
          d["positions"] = to_array(&m.positions.data()->x, {m.positions.size(), size_t{3}});
          d["indices"] = to_array(m.indices.data(), {m.triangle_count(), size_t{3}});
          d["material_ids"] = to_array(m.material_ids.data(), {m.material_ids.size()});
          d["normals"] = m.normals.empty() ? py::object(py::none())
                                           : py::object(to_array(&m.normals.data()->x, {m.normals.size(), size_t{3}}));
          out.append(d);
        }
        return out;
      }, "Meshes as {name, positions (N,3) float32, indices (M,3) uint32, material_ids (M,), normals or None}")
      .def("materials", [](const Scene& s) {
        py::list out;
        for (const Material& m : s.materials) {
          py::dict d;
          d["name"] = m.name;
          d["type"] = to_string(m.type);
          d["color"] = py::make_tuple(m.color.r, m.color.g, m.color.b);
          d["roughness"] = m.roughness;
          d["ior"] = m.ior;
          d["cauchy_b"] = m.cauchy_b;
          d["emission"] = py::make_tuple(m.emission.r, m.emission.g, m.emission.b);
          d["strength"] = m.emission_strength;
          d["two_sided"] = m.two_sided;
          out.append(d);
        }
        return out;
      }, "Materials as dicts in the scene format's units (roughness = GGX alpha)")
      .def("lights", [](const Scene& s) {
        py::list out;
        static const char* kinds[] = {"area", "point", "spot", "sun", "environment"};
        for (const Light& l : s.lights) {
          py::dict d;
          d["name"] = l.name;
          d["type"] = kinds[static_cast<int>(l.type)];
          d["emit"] = py::make_tuple(l.emit.r, l.emit.g, l.emit.b);  // intensity, irradiance or radiance
          d["position"] = py::make_tuple(l.position.x, l.position.y, l.position.z);
          d["direction"] = py::make_tuple(l.direction.x, l.direction.y, l.direction.z);
          d["spot_cos_half"] = l.spot_cos_half;
          d["spot_smooth"] = l.spot_smooth;
          d["radius"] = l.radius;  // point/spot: Blender's light radius (a disk facing the shading point)
          out.append(d);
        }
        return out;
      }, "Point, spot, sun and environment lights (emissive meshes are in meshes/materials)")
      .def("camera", [](const Scene& s) {
        const Camera& c = s.camera;
        py::dict d;
        py::list rows;
        for (const auto& row : c.camera_to_world.m) rows.append(py::make_tuple(row[0], row[1], row[2], row[3]));
        d["matrix"] = rows;
        d["fov"] = c.fov_degrees;
        d["sensor_fit"] = c.sensor_fit == SensorFit::Auto ? "auto" : c.sensor_fit == SensorFit::Horizontal ? "horizontal" : "vertical";
        d["width"] = c.width;
        d["height"] = c.height;
        d["aperture_radius"] = c.aperture_radius;
        d["focus_distance"] = c.focus_distance;
        d["clip_start"] = c.clip_start;
        d["clip_end"] = c.clip_end;  // inf: no far clip
        d["type"] = c.projection == Projection::Orthographic ? "orthographic" : "perspective";
        d["ortho_scale"] = c.ortho_scale;
        d["shift"] = py::make_tuple(c.shift.x, c.shift.y);
        d["pixel_filter"] = py::dict(py::arg("type") = std::string(c.filter.type_name()),
                                     py::arg("width") = c.filter.width());
        d["crop"] = c.crop_width > 0 ? py::object(py::make_tuple(c.crop_x, c.crop_y, c.crop_width, c.crop_height))
                                     : py::object(py::none());
        return d;
      }, "Camera: camera-to-world matrix rows (looks down -Z, +Y up), fov in degrees, size, lens, shift, crop")
      // ---- Updates (the rendered viewport): a Session made before one stops rendering (make a new one)
      .def_property_readonly("generation", &Scene::generation, "Advances with every update")
      .def_property_readonly("mesh_names", [](const Scene& s) {
        std::vector<std::string> n;
        for (const Mesh& m : s.meshes) n.push_back(m.name);
        return n;
      }, "Mesh names in index order (an instance of an array mesh is one mesh)")
      .def("set_camera", [](Scene& s, const std::string& camera_json) {
        Scene::UpdateGuard guard(s);
        set_camera(s, camera_json);
      }, py::arg("camera_json"), "Replace the camera (the scene format's camera object as JSON text)")
      .def("set_transforms", [](Scene& s, const std::vector<size_t>& meshes, const py::object& matrices) {
        const std::vector<Transform> t = transforms_from_array(matrices, "set_transforms");
        if (t.size() != meshes.size())
          throw py::value_error(fmt::format("{} mesh indices for {} matrices", meshes.size(), t.size()));
        py::gil_scoped_release release;
        Scene::UpdateGuard guard(s);
        try {
          for (size_t i = 0; i < meshes.size(); ++i) s.set_mesh_transform(meshes[i], t[i]);
        } catch (...) {
          s.commit();  // the meshes moved before the bad one: the accelerator follows them
          throw;
        }
        s.commit();
      }, py::arg("meshes"), py::arg("matrices"),
         "Move meshes built from arrays: indices into mesh_names and (K,4,4) object-to-world matrices; "
         "their arrays are transformed again natively and only their part of the BVH changes")
      .def("update_description", [](Scene& s, const std::string& json_text) {
        py::gil_scoped_release release;
        Scene::UpdateGuard guard(s);
        update_description(s, json_text);
      }, py::arg("json_text"),
         "Replace materials (by name), lights, environment and (if given) the camera from a description "
         "without objects; SceneError when a material an object uses is missing");

  m.def("load_scene", [](const std::string& path) {
    py::gil_scoped_release release;
    return std::make_shared<Scene>(load_scene(path));
  }, py::arg("path"), "Load and prepare a JSON scene file");
  m.def("load_scene_json", [](const std::string& text, const std::string& base_dir) {
    py::gil_scoped_release release;
    return std::make_shared<Scene>(load_scene_from_string(text, base_dir, "<json>"));
  }, py::arg("text"), py::arg("base_dir") = ".", "Load a scene from JSON text");

}

// Scenes built from numpy arrays (the Blender exporter).
void bind_builder(py::module_& m) {
  py::class_<SceneBuilder>(m, "SceneBuilder",
                           "A Scene from numpy arrays (exporters): description for the small parts, arrays for meshes")
      .def(py::init<std::string>(), py::arg("source") = "<builder>")
      .def("set_description", &SceneBuilder::set_description, py::arg("json_text"),
           "Camera, materials, lights, environment in the JSON scene format")
      .def("add_mesh",
           [](SceneBuilder& b, const std::string& name, const py::object& positions, const py::object& indices,
              const std::vector<std::string>& materials, const py::object& material_ids, const py::object& normals,
              const py::object& uvs, const py::object& matrices, const std::vector<std::string>& instance_names,
              const py::object& motion, const py::object& motion_positions, const py::object& attributes,
              const py::object& default_color, const std::vector<std::optional<uint32_t>>& instance_random_ids) {
             MeshArrays in;
             in.name = name;
             in.materials = materials;
             auto pos = exact_array<float>(positions, name, "positions", 3, "float32");
             auto idx = exact_array<uint32_t>(indices, name, "indices", 3, "uint32");
             in.positions = pos.data();
             in.vertex_count = pos.size() / 3;
             in.indices = idx.data();
             in.triangle_count = idx.size() / 3;
             py::array_t<uint32_t> mid;
             py::array_t<float> nrm, uv;
             if (!material_ids.is_none()) {
               mid = exact_array<uint32_t>(material_ids, name, "material_ids", 1, "uint32");
               if (static_cast<size_t>(mid.size()) != in.triangle_count)
                 throw py::value_error("object '" + name + "': material_ids needs one entry per triangle");
               in.material_ids = mid.data();
             }
             if (!normals.is_none()) {
               nrm = exact_array<float>(normals, name, "normals", 3, "float32");
               if (static_cast<size_t>(nrm.size()) != 3 * in.vertex_count)
                 throw py::value_error("object '" + name + "': normals needs one entry per vertex");
               in.normals = nrm.data();
             }
             if (!uvs.is_none()) {
               uv = exact_array<float>(uvs, name, "uvs", 2, "float32");
               if (static_cast<size_t>(uv.size()) != 2 * in.vertex_count)
                 throw py::value_error("object '" + name + "': uvs needs one entry per vertex");
               in.uvs = uv.data();
             }
             in.instances = transforms_from_array(matrices, name);
             // An empty (0, 4, 4) array means no copy at all (None means one, untransformed).
             if (!matrices.is_none() && in.instances.empty()) return;
             in.instance_names = instance_names;
             in.instance_random_ids = instance_random_ids;
             // Motion blur: (K, S, 4, 4) object-to-world matrices over the shutter, (S', N, 3) positions.
             if (!motion.is_none()) {
               auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(motion);
               const size_t k = in.instances.empty() ? 1 : in.instances.size();
               if (!a || a.ndim() != 4 || static_cast<size_t>(a.shape(0)) != k || a.shape(2) != 4 || a.shape(3) != 4)
                 throw py::value_error(fmt::format("object '{}': motion must be a ({}, S, 4, 4) array (per instance its "
                                                   "S object-to-world matrices over the shutter)", name, k));
               if (a.shape(1) < 2)
                 throw py::value_error(fmt::format("object '{}': motion has {} matrix per instance; give at least 2 "
                                                   "(shutter open and close)", name, a.shape(1)));
               const size_t steps = a.shape(1);
               const float* d = a.data();
               in.motion.assign(k, std::vector<Transform>(steps));
               for (size_t i = 0; i < k; ++i)
                 for (size_t st = 0; st < steps; ++st)
                   for (int r = 0; r < 4; ++r)
                     for (int c = 0; c < 4; ++c) in.motion[i][st].m[r][c] = d[16 * (i * steps + st) + 4 * r + c];
             }
             py::array_t<float> mp;
             if (!motion_positions.is_none()) {
               if (!py::isinstance<py::array_t<float>>(motion_positions))
                 throw py::type_error(fmt::format("object '{}': motion_positions must be a numpy float32 array", name));
               mp = motion_positions.cast<py::array_t<float>>();
               if (!(mp.flags() & py::array::c_style) || mp.ndim() != 3 ||
                   static_cast<size_t>(mp.shape(1)) != in.vertex_count || mp.shape(2) != 3)
                 throw py::value_error(fmt::format("object '{}': motion_positions must be a C-contiguous (S, {}, 3) "
                                                   "array (S steps of the mesh's vertices)", name, in.vertex_count));
               if (mp.shape(0) < 2)
                 throw py::value_error(fmt::format("object '{}': motion_positions has {} step; give at least 2 "
                                                   "(shutter open and close)", name, mp.shape(0)));
               in.motion_positions = mp.data();
               in.motion_steps = mp.shape(0);
             }
             in.attributes = attributes_from_list(attributes, default_color, name);
             py::gil_scoped_release release;
             b.add_mesh(in);
           },
           py::arg("name"), py::arg("positions"), py::arg("indices"), py::arg("materials"),
           py::arg("material_ids") = py::none(), py::arg("normals") = py::none(), py::arg("uvs") = py::none(),
           py::arg("matrices") = py::none(), py::arg("instance_names") = std::vector<std::string>(),
           py::arg("motion") = py::none(), py::arg("motion_positions") = py::none(), py::arg("attributes") = py::none(),
           py::arg("default_color") = py::none(),
           py::arg("instance_random_ids") = std::vector<std::optional<uint32_t>>(),
           "Add a mesh: positions float32 (N,3), indices uint32 (M,3), material names with optional uint32 "
           "material_ids (M,), optional float32 normals (N,3) and uvs (N,2), optional (K,4,4) object-to-world "
           "matrices (one world-space copy per matrix); motion blur: optional motion (K,S,4,4), each instance's "
           "S >= 2 matrices over the shutter, and motion_positions float32 (S',N,3), object-space vertices per step; "
           "optional instance_random_ids (K,) of int or None, Object Info's Random per instance (None: the name's hash); "
           "optional attributes [(name, 'point' | 'corner' | 'face', float32 (N,) or (N,k))] for Color Attribute / "
           "Attribute nodes, with default_color naming the render colour attribute")
      .def_property_readonly("triangle_count", &SceneBuilder::triangle_count)
      .def("finalize", [](SceneBuilder& b) {
        py::gil_scoped_release release;
        return std::make_shared<Scene>(b.finalize());
      }, "Validate and build the scene (errors name the object)");

}

// Progressive renders (session/render_session.h).
void bind_session(py::module_& m) {
  py::class_<Session>(m, "Session")
      .def(py::init<std::shared_ptr<Scene>, const std::string&, const py::dict&>(), py::arg("scene"),
           py::arg("method") = "pt", py::arg("params") = py::dict())
      .def("iterate", &Session::iterate, py::arg("seconds") = 0.0,
           "Render one pass (releases the GIL); with seconds > 0, methods whose passes can pause at a tile "
           "(pt, spt, spt-hero) return after about that long and go on with the same pass at the next call "
           "(stats['passes'] counts whole passes)")
      .def("run", &Session::run, py::arg("seconds") = 0.0, py::arg("passes") = 0,
           "Render until the time budget or pass count is reached, or cancel() is called")
      .def("cancel", &Session::cancel, "Ask the current pass to stop (thread-safe)")
      .def_property_readonly("cancelled", &Session::cancelled)
      .def("develop", &Session::develop, py::arg("display") = false,
           "Current passes as {name: float32 array (H, W, C)}; display=True: an image to show while the "
           "render runs, which a gradient method reconstructs by L2 (one linear solve) instead of L1")
      .def("set_aux_passes", &Session::set_aux_passes, py::arg("on"),
           "Whether to make the albedo, normal and depth passes (on by default)")
      .def("write_exr", &Session::write_exr_file, py::arg("path"), "Write every pass, with run_info in the header")
      .def_property_readonly("run_info", &Session::run_info,
                             "The run's record for EXR headers: {'gradphoton.method': ..., 'gradphoton.seed': ...}")
      .def_property_readonly("stats", &Session::stats)
      .def_property_readonly("stale", &Session::stale, "Whether the scene was updated since this Session was made")
      .def_property_readonly("unused_params", &Session::unused)
      .def_property_readonly("unused_report", &Session::unused_report,
                             "One line per unused parameter: not the method's (with a near name), or not read "
                             "with these settings")
      .def_property_readonly("feature_report", &Session::feature_report,
                             "One line per scene feature the method leaves out (participating media), naming it")
      .def("stop_report", &Session::stop_report, py::arg("seconds") = 0.0, py::arg("passes") = 0,
           py::arg("target_error") = 0.0,
           "One line per thing this stop rule asks that the method cannot give on this scene (a Target Error "
           "with media)")
      .def_property_readonly("passes", &Session::passes,
                             "The passes develop() writes, as the method declares them for these params on this "
                             "scene ('alpha' with Film > Transparent or a holdout in the scene), the auxiliary "
                             "albedo/normal/depth aside")
      .def_property_readonly("method", &Session::method,
                             "The method that runs (pt becomes spt-hero in spectral mode)")
      .def("error_terms", &Session::error_terms,
           "Photon methods: the terms of each pixel's error bound (radiance, bias, bias_sd, noise_sd, sigma, "
           "bound, radius; luminance) as {name: float64 array (H, W)}")
      .def_property_readonly("estimated_error", &Session::estimated_error,
                             "Current estimated relative error, or < 0 when the method has none");
}

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() = "gradphoton native core";
  m.attr("__version__") = GRADPHOTON_VERSION;
  py::register_exception<SceneError>(m, "SceneError", PyExc_ValueError);
  py::register_exception<VdbError>(m, "VdbError", PyExc_ValueError);
  py::register_exception<ParamError>(m, "ParamError", PyExc_ValueError);

  bind_methods(m);
  bind_images(m);
  bind_scene(m);
  bind_builder(m);
  bind_session(m);
}
