// pybind11 module gradphoton._native: the core as the addon and scripts see it. pybind11
// types stay in this file; native work releases the GIL so Blender's UI stays responsive.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>

#include "core/film.h"
#include "integrators/integrator.h"
#include "io/exr.h"
#include "scene/loader.h"

namespace py = pybind11;
using namespace gp;

namespace {

// Python dict -> Params, through JSON text (values are plain numbers, strings and lists).
Params params_from_dict(const py::dict& d) {
  py::object dumps = py::module_::import("json").attr("dumps");
  return Params(nlohmann::json::parse(dumps(d).cast<std::string>()));
}

// One progressive render: owns the scene and the integrator.
class Session {
 public:
  Session(std::shared_ptr<Scene> scene, const std::string& method, const py::dict& params)
      : scene_(std::move(scene)) {
    Params p = params_from_dict(params);
    integrator_ = make_integrator(method, *scene_, p);
    unused_ = p.unused();
  }
  void iterate() {
    py::gil_scoped_release release;
    integrator_->iterate(&sink_);
  }
  void run(double seconds, int64_t passes) {
    py::gil_scoped_release release;
    run_progressive(*integrator_, StopRule{seconds, passes, 0}, &sink_);
  }
  void cancel() { sink_.cancel_flag = true; }
  bool cancelled() { return sink_.cancel_flag; }
  // Every pass as a float32 array of shape (height, width, channels), row 0 at the top.
  py::dict develop() {
    Film film;
    {
      py::gil_scoped_release release;
      integrator_->develop(film);
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
    Film film;
    integrator_->develop(film);
    write_exr(path, film);
  }
  py::dict stats() const {
    const Stats& s = integrator_->stats();
    py::dict d;
    d["passes"] = s.passes;
    d["paths"] = s.paths;
    d["rays"] = s.rays;
    d["invalid_samples"] = s.invalid_samples;
    d["seconds"] = s.seconds;
    for (const auto& [k, v] : s.extra) d[py::str(k)] = v;
    return d;
  }
  const std::vector<std::string>& unused() const { return unused_; }

 private:
  std::shared_ptr<Scene> scene_;
  std::unique_ptr<Integrator> integrator_;
  ProgressSink sink_;
  std::vector<std::string> unused_;
};

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() = "gradphoton native core";
  m.attr("__version__") = GRADPHOTON_VERSION;
  m.attr("PASS_COMBINED") = std::string(pass::kCombined);
  m.def("methods", &integrator_names, "Names of the rendering methods");

  py::register_exception<SceneError>(m, "SceneError", PyExc_ValueError);
  py::register_exception<ParamError>(m, "ParamError", PyExc_ValueError);

  py::class_<Scene, std::shared_ptr<Scene>>(m, "Scene")
      .def_property_readonly("triangle_count", &Scene::triangle_count)
      .def_property_readonly("light_count", [](const Scene& s) { return s.light_set().lights().size(); })
      .def_property_readonly("material_names", [](const Scene& s) {
        std::vector<std::string> n;
        for (const auto& m : s.materials) n.push_back(m.name);
        return n;
      })
      .def_property_readonly("warnings", [](const Scene& s) { return s.warnings.summary(); })
      .def_property("width", [](const Scene& s) { return s.camera.width; },
                    [](Scene& s, int w) { s.camera.width = w; })
      .def_property("height", [](const Scene& s) { return s.camera.height; },
                    [](Scene& s, int h) { s.camera.height = h; });

  m.def("load_scene", [](const std::string& path) {
    py::gil_scoped_release release;
    return std::make_shared<Scene>(load_scene(path));
  }, py::arg("path"), "Load and prepare a JSON scene file");
  m.def("load_scene_json", [](const std::string& text, const std::string& base_dir) {
    py::gil_scoped_release release;
    return std::make_shared<Scene>(load_scene_from_string(text, base_dir, "<json>"));
  }, py::arg("text"), py::arg("base_dir") = ".", "Load a scene from JSON text");

  py::class_<Session>(m, "Session")
      .def(py::init<std::shared_ptr<Scene>, const std::string&, const py::dict&>(), py::arg("scene"),
           py::arg("method") = "pt", py::arg("params") = py::dict())
      .def("iterate", &Session::iterate, "Render one pass (releases the GIL)")
      .def("run", &Session::run, py::arg("seconds") = 0.0, py::arg("passes") = 0,
           "Render until the time budget or pass count is reached, or cancel() is called")
      .def("cancel", &Session::cancel, "Ask the current pass to stop (thread-safe)")
      .def_property_readonly("cancelled", &Session::cancelled)
      .def("develop", &Session::develop, "Current passes as {name: float32 array (H, W, C)}")
      .def("write_exr", &Session::write_exr_file, py::arg("path"))
      .def_property_readonly("stats", &Session::stats)
      .def_property_readonly("unused_params", &Session::unused);
}
