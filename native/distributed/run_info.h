// What one render did, recorded in the header of every EXR gradphoton writes (CLI, Python,
// Blender) so that any set of outputs can be merged (distributed/merge.h) or audited later
// (DESIGN.md, "Beyond one machine").
//
// Each field is one OpenEXR string attribute named "gradphoton.<field>" (io/exr.h writes and
// reads string attributes). Strings, not typed attributes, because Blender can only add string
// fields to the files it saves (RenderResult.stamp_data_add_field); one format for all three.
//   gradphoton.method      the integrator that ran (Integrator::name(): "pt" may run as "spt")
//   gradphoton.seed        the seed; a merged file lists its runs' seeds, "1,2,3"
//   gradphoton.runs        how many runs the file holds (1, or the merged count)
//   gradphoton.passes      passes rendered (summed over runs)
//   gradphoton.paths       camera paths, photons or mutations traced (Stats::paths, summed):
//                          the work merge weighs each run by
//   gradphoton.seconds     render seconds inside iterate() (summed over runs)
//   gradphoton.size        "WxH"
//   gradphoton.params      the method's parameters as given, JSON (nlohmann), without the
//                          run-specific ones (seed, threads)
//   gradphoton.scene       where the scene came from (file name, or Blender's .blend)
//   gradphoton.scene_hash  fingerprint of geometry, materials, lights and camera (16 hex digits)
//   gradphoton.version     gradphoton's version
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/progress.h"

namespace gp {

class Scene;

struct RunInfo {
  std::string method;
  std::vector<uint64_t> seeds;
  int64_t runs = 1;
  int64_t passes = 0;
  int64_t paths = 0;
  double seconds = 0;
  int width = 0, height = 0;
  nlohmann::json params = nlohmann::json::object();
  std::string scene, scene_hash;
  std::string version = GRADPHOTON_VERSION;
};

// Parameters that differ between independent runs of the same render (not compared by merge).
inline const char* const kRunSpecificParams[] = {"seed", "threads"};

// The record of a render: `method` is the integrator's name, `params` what it was built from.
RunInfo make_run_info(const std::string& method, const Params& params, const Stats& stats, const Scene& scene);

// 64-bit FNV-1a over the scene's meshes, materials, lights and camera (not the image size).
std::string scene_fingerprint(const Scene& scene);

// RunInfo <-> "gradphoton.*" string attributes.
std::map<std::string, std::string> to_attributes(const RunInfo& run);
// Throws std::runtime_error naming `path` when the attributes are missing or malformed.
RunInfo from_attributes(const std::map<std::string, std::string>& attributes, const std::string& path);
// True when the attributes hold any gradphoton.* field.
bool has_run_info(const std::map<std::string, std::string>& attributes);

}  // namespace gp
