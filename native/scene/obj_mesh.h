// Wavefront OBJ files as scene objects (docs/scene-format.md, object type "obj"), read with
// tinyobjloader: one triangle mesh per file, vertices shared where position, normal and uv
// indices agree, faces' usemtl names resolved against the scene's materials.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "core/log.h"
#include "scene/json_reader.h"
#include "scene/scene.h"

namespace gp {

struct ObjMaterials {
  std::function<std::optional<uint32_t>(const std::string&)> by_name;  // a scene material by name
  std::optional<uint32_t> fallback;  // the object's 'material', for faces without a known usemtl
  std::string known;                 // the scene's material names, for messages
};

// Reads `file` into a mesh. Errors name the reader's file and the JSON path `fpath` of the
// object's "file" key (`path` of the object); warnings go to `warnings`.
Mesh read_obj_mesh(const JsonReader& r, const std::filesystem::path& file, const std::string& path,
                   const std::string& fpath, const std::string& name, const ObjMaterials& materials,
                   Warnings& warnings);

}  // namespace gp
