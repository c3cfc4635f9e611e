// SceneBuilder: a Scene from arrays, for exporters (the Blender addon) that already hold
// triangle meshes in memory. The small parts of a scene (camera, materials, lights,
// environment) are a JSON description read by the scene-file loader, so their units and
// validation are those of docs/scene-format.md; meshes arrive as flat arrays and never pass
// through JSON.
//
// Instances: one mesh with several object-to-world matrices is copied into world space once
// per matrix (in parallel, in native code). Embree instancing would share the geometry; the
// accelerator does not use it yet, so memory grows with the instance count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace gp {

// Borrowed views of one mesh's arrays (the caller keeps them alive during add_mesh).
struct MeshArrays {
  std::string name;                     // the exporter's object name, used in errors
  const float* positions = nullptr;     // vertex_count * 3
  size_t vertex_count = 0;
  const uint32_t* indices = nullptr;    // triangle_count * 3
  size_t triangle_count = 0;
  const float* normals = nullptr;       // optional, vertex_count * 3
  const float* uvs = nullptr;           // optional, vertex_count * 2
  const uint32_t* material_ids = nullptr;  // optional, triangle_count (index into `materials`)
  std::vector<std::string> materials;   // material names of the description; at least one
  // Object-to-world matrices (row-major 4x4, affine). Empty = one copy, identity.
  std::vector<Transform> instances;
  std::vector<std::string> instance_names;  // optional, one per instance (default: name)
  // Optional, one per instance: Object Info's Random id (Mesh::random_id; unset: by name).
  std::vector<std::optional<uint32_t>> instance_random_ids;
  // Motion blur (docs/scene-format.md): per instance its S >= 2 object-to-world matrices over the
  // shutter (empty: none; `instances` stays the frame's own); an instance whose matrices are all
  // equal is static. Deformation: motion_steps >= 2 object-space vertex arrays, each
  // vertex_count * 3 floats (null / 0: none).
  std::vector<std::vector<Transform>> motion;
  const float* motion_positions = nullptr;
  size_t motion_steps = 0;
  // Optional named attributes (Color Attribute / Attribute nodes), shared by the instances;
  // checked against the mesh when the scene is finalized.
  std::shared_ptr<const shading::MeshAttributes> attributes;
};

// ---- Updates of a finalized scene (the rendered viewport; scene.h "Updates") ----
// From the same JSON description SceneBuilder takes, without "objects": materials are replaced
// by name and keep their indices (so meshes keep theirs; a material a mesh uses must still be
// described, else SceneError and the caller rebuilds), new names are added; lights and the
// environment are replaced; the camera is replaced when the description has one. Commits
// (emission, visibility and the light set follow the new materials).
void update_description(Scene& scene, const std::string& json_text);
// Replaces the camera by a description's "camera" object (JSON text). Throws SceneError.
void set_camera(Scene& scene, const std::string& camera_json);

class SceneBuilder {
 public:
  // `source` names the scene in messages ("Blender scene 'Scene'").
  explicit SceneBuilder(std::string source);

  // Camera, materials, lights and environment in the JSON scene format (objects allowed too).
  // Replaces an earlier description. Throws SceneError.
  void set_description(const std::string& json_text);
  // Validates and copies one mesh (once per instance). Throws SceneError naming the object.
  void add_mesh(const MeshArrays& mesh);
  size_t triangle_count() const;

  // Resolves material names, finalizes and hands over the scene; the builder is empty after.
  // Throws SceneError naming the object at fault.
  Scene finalize();

 private:
  struct Pending {
    Mesh mesh;  // material_ids index `materials`
    std::vector<std::string> materials;
  };
  std::string source_;
  std::string description_ = "{}";
  std::vector<Pending> meshes_;
};

}  // namespace gp
