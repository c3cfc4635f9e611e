// JSON scene files (format: docs/scene-format.md). The loader builds a gp::Scene from the
// camera, materials, objects (inline meshes, OBJ files, analytic shapes tessellated by
// scene/shapes), lights and environment of a file, then finalizes it.
//
// Like pbrt's parameter dictionaries it reports what it did not use: every unknown key is a
// counted warning ("unknown key", "<file>: <JSON path>") in Scene::warnings. Everything that
// would make the scene wrong (wrong types, wrong array lengths, non-finite numbers, negative
// sizes, unknown material names, out-of-range indices, missing files) throws SceneError whose
// message names the file and the JSON path at fault, e.g.
//   scenes/x.json: /objects/3/material: unknown material 'glas' (known: glass, white)
#pragma once

#include <stdexcept>
#include <string>

#include "scene/scene.h"

namespace gp {

class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Loads and finalizes the scene in `path`; relative paths inside (OBJ files) are resolved
// against the directory of `path`. scene.source = path.
Scene load_scene(const std::string& path);

// Same from JSON text already in memory. `base_dir` resolves relative file names;
// `name_for_messages` is the file name used in errors and warnings and becomes scene.source.
Scene load_scene_from_string(const std::string& json_text, const std::string& base_dir,
                             const std::string& name_for_messages);

// Same as load_scene_from_string but without finalize(): the scene builder (scene/builder.h)
// parses the small parts of a scene (camera, materials, lights, environment) through here so
// their units and validation are defined once, then adds array meshes and finalizes.
Scene parse_scene_from_string(const std::string& json_text, const std::string& base_dir,
                              const std::string& name_for_messages);

// scene.finalize() with its errors (which name the mesh) turned into SceneError.
void finalize_scene(Scene& scene);

}  // namespace gp
