#include "scene/builder.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <map>

#include "scene/loader.h"
#include "scene/shapes.h"

namespace gp {

SceneBuilder::SceneBuilder(std::string source) : source_(std::move(source)) {}

void SceneBuilder::set_description(const std::string& json_text) {
  // Parse now so a bad description fails at the call that gave it.
  (void)parse_scene_from_string(json_text, ".", source_);
  description_ = json_text;
}

size_t SceneBuilder::triangle_count() const {
  size_t n = 0;
  for (const auto& p : meshes_) n += p.mesh.triangle_count();
  return n;
}

void SceneBuilder::add_mesh(const MeshArrays& in) {
  auto fail = [&](const std::string& what) {
    throw SceneError(fmt::format("{}: object '{}': {}", source_, in.name, what));
  };
  if (in.materials.empty()) fail("needs at least one material");
  if (in.vertex_count > 0 && !in.positions) fail("positions missing");
  if (in.triangle_count > 0 && !in.indices) fail("indices missing");
  const size_t nv = in.vertex_count, nt = in.triangle_count;
  for (size_t k = 0; k < 3 * nt; ++k)
    if (in.indices[k] >= nv)
      fail(fmt::format("triangle {} uses vertex {} but the mesh has {} vertices", k / 3, in.indices[k], nv));
  if (in.material_ids)
    for (size_t t = 0; t < nt; ++t)
      if (in.material_ids[t] >= in.materials.size())
        fail(fmt::format("triangle {} uses material slot {} but the object has {} materials", t, in.material_ids[t],
                         in.materials.size()));
  for (size_t k = 0; k < 3 * nv; ++k)
    if (!std::isfinite(in.positions[k])) fail(fmt::format("vertex {} is not finite", k / 3));
  if (!in.instance_names.empty() && in.instance_names.size() != in.instances.size())
    fail(fmt::format("{} instance names for {} instances", in.instance_names.size(), in.instances.size()));
  if (!in.instance_random_ids.empty() && in.instance_random_ids.size() != std::max<size_t>(1, in.instances.size()))
    fail(fmt::format("{} instance random ids for {} instances", in.instance_random_ids.size(), in.instances.size()));

  std::vector<Transform> instances = in.instances;
  if (instances.empty()) instances.emplace_back();
  if (!in.motion.empty() && in.motion.size() != instances.size())
    fail(fmt::format("motion for {} instances but the object has {}", in.motion.size(), instances.size()));
  if (in.motion_steps == 1) fail("'motion_positions' has 1 step: give at least 2 (shutter open and close)");
  if (in.motion_steps > 1 && !in.motion_positions) fail("motion_positions missing");
  std::vector<std::vector<Vec3>> deform(in.motion_steps, std::vector<Vec3>(nv));
  for (size_t s = 0; s < deform.size(); ++s)
    for (size_t v = 0; v < nv; ++v) {
      const float* p = in.motion_positions + 3 * (s * nv + v);
      deform[s][v] = Vec3(p[0], p[1], p[2]);
    }
  for (size_t i = 0; i < instances.size(); ++i) {
    const std::string name = in.instance_names.empty() ? in.name : in.instance_names[i];
    if (const std::string bad = check_object_matrix(instances[i]); !bad.empty())
      throw SceneError(fmt::format("{}: object '{}': {}", source_, name, bad));
  }
  // Object space, once for all instances (Scene::set_mesh_transform moves an instance from it).
  auto src = std::make_shared<MeshSource>();
  src->positions.resize(nv);
  for (size_t v = 0; v < nv; ++v) src->positions[v] = Vec3(in.positions[3 * v], in.positions[3 * v + 1], in.positions[3 * v + 2]);
  if (in.normals) {
    src->normals.resize(nv);
    for (size_t v = 0; v < nv; ++v) src->normals[v] = Vec3(in.normals[3 * v], in.normals[3 * v + 1], in.normals[3 * v + 2]);
  }
  for (size_t i = 0; i < instances.size(); ++i) {
    Pending p;
    p.materials = in.materials;
    Mesh& m = p.mesh;
    m.name = in.instance_names.empty() ? in.name : in.instance_names[i];
    if (!in.instance_random_ids.empty()) m.random_id = in.instance_random_ids[i];
    m.indices.assign(in.indices, in.indices + 3 * nt);
    const std::vector<Transform> no_motion;
    const std::vector<Transform>& motion = in.motion.empty() ? no_motion : in.motion[i];
    if (!motion.empty() || !deform.empty()) {  // motion blur: object space kept beside the frame's
      m.positions = src->positions;
      m.normals = src->normals;
      try {
        set_mesh_motion(m, instances[i], motion, deform);
      } catch (const std::invalid_argument& e) {
        throw SceneError(fmt::format("{}: object '{}': {}", source_, m.name, e.what()));
      }
    } else {
      transform_mesh(*src, instances[i], m);  // world space, winding kept for a mirroring matrix
      m.source = src;
    }
    if (in.uvs) {
      m.uvs.resize(nv);
      for (size_t v = 0; v < nv; ++v) m.uvs[v] = Vec2(in.uvs[2 * v], in.uvs[2 * v + 1]);
    }
    m.attributes = in.attributes;
    if (in.material_ids) m.material_ids.assign(in.material_ids, in.material_ids + nt);
    else m.material_ids.assign(nt, 0);
    meshes_.push_back(std::move(p));
  }
}

Scene SceneBuilder::finalize() {
  Scene scene = parse_scene_from_string(description_, ".", source_);
  std::map<std::string, uint32_t> index;
  for (size_t i = 0; i < scene.materials.size(); ++i) index[scene.materials[i].name] = static_cast<uint32_t>(i);
  for (Pending& p : meshes_) {
    std::vector<uint32_t> remap;
    for (const std::string& n : p.materials) {
      auto it = index.find(n);
      if (it == index.end())
        throw SceneError(fmt::format("{}: object '{}': unknown material '{}'", source_, p.mesh.name, n));
      remap.push_back(it->second);
    }
    for (uint32_t& id : p.mesh.material_ids) id = remap[id];
    scene.meshes.push_back(std::move(p.mesh));
  }
  meshes_.clear();
  finalize_scene(scene);
  return scene;
}

// ---- Updates ----

void update_description(Scene& scene, const std::string& json_text) {
  const std::string source = scene.source.empty() ? std::string("<scene>") : scene.source;
  scene.check_not_rendering("update materials and lights");
  Scene next = parse_scene_from_string(json_text, ".", source);
  if (!next.meshes.empty())
    throw SceneError(fmt::format("{}: a description update has no objects (meshes are added by arrays)", source));
  const bool has_camera = nlohmann::json::parse(json_text).contains("camera");
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < next.materials.size(); ++i) index[next.materials[i].name] = i;
  // Which materials the meshes use: those must survive.
  std::vector<bool> used(scene.materials.size(), false);
  for (const Mesh& m : scene.meshes)
    for (uint32_t id : m.material_ids) used[id] = true;
  std::vector<Material> materials = scene.materials;
  std::vector<bool> visibility_changed(materials.size(), false);
  for (size_t i = 0; i < materials.size(); ++i) {
    auto it = index.find(materials[i].name);
    if (it == index.end()) {
      if (used[i])
        throw SceneError(fmt::format("{}: material '{}' is used by an object but not in the update", source,
                                     materials[i].name));
      continue;
    }
    const Material& n = next.materials[it->second];
    visibility_changed[i] = n.visible_to_camera != materials[i].visible_to_camera ||
                            n.casts_shadow != materials[i].casts_shadow ||
                            n.visible_lobes != materials[i].visible_lobes ||
                            n.transparent_shadow() != materials[i].transparent_shadow();
    materials[i] = n;
    index.erase(it);
  }
  for (size_t i = 0; i < next.materials.size(); ++i)
    if (index.count(next.materials[i].name)) materials.push_back(next.materials[i]);
  scene.materials = std::move(materials);
  scene.lights = std::move(next.lights);
  scene.media = std::move(next.media);  // the materials' interiors index the update's media
  scene.world_medium = next.world_medium;
  scene.volume_bounces = next.volume_bounces;
  scene.transparent_bounces = next.transparent_bounces;
  scene.filter_glossy = next.filter_glossy;
  scene.caustics_reflective = next.caustics_reflective;
  scene.caustics_refractive = next.caustics_refractive;
  if (has_camera) scene.camera = next.camera;
  scene.warnings = std::move(next.warnings);
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
    for (uint32_t id : scene.meshes[mi].material_ids)
      if (visibility_changed[id]) {
        scene.mark_mesh_changed(mi);  // its ray-visibility filters
        break;
      }
  try {
    scene.commit();
  } catch (const std::runtime_error& e) {  // Scene::build_lights names the light or mesh
    throw SceneError(e.what());
  }
}

void set_camera(Scene& scene, const std::string& camera_json) {
  const std::string source = scene.source.empty() ? std::string("<scene>") : scene.source;
  nlohmann::json root;
  try {
    root["camera"] = nlohmann::json::parse(camera_json);
  } catch (const nlohmann::json::exception& e) {
    throw SceneError(fmt::format("{}: camera: not JSON: {}", source, e.what()));
  }
  Scene next = parse_scene_from_string(root.dump(), ".", source);
  scene.set_camera(next.camera);
}

}  // namespace gp
