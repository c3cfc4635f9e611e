#include "scene/builder.h"

#include "core/parallel.h"

#include <fmt/format.h>

#include <cmath>
#include <map>

#include "scene/loader.h"
#include "scene/shapes.h"

namespace gp {

namespace {

// Inverse transpose of the 3x3 part (for normals), up to a positive scale.
void normal_matrix(const Transform& t, float out[3][3]) {
  const auto& m = t.m;
  // Cofactor matrix = det * inverse transpose; the sign of det is folded back in.
  out[0][0] = m[1][1] * m[2][2] - m[1][2] * m[2][1];
  out[0][1] = m[1][2] * m[2][0] - m[1][0] * m[2][2];
  out[0][2] = m[1][0] * m[2][1] - m[1][1] * m[2][0];
  out[1][0] = m[0][2] * m[2][1] - m[0][1] * m[2][2];
  out[1][1] = m[0][0] * m[2][2] - m[0][2] * m[2][0];
  out[1][2] = m[0][1] * m[2][0] - m[0][0] * m[2][1];
  out[2][0] = m[0][1] * m[1][2] - m[0][2] * m[1][1];
  out[2][1] = m[0][2] * m[1][0] - m[0][0] * m[1][2];
  out[2][2] = m[0][0] * m[1][1] - m[0][1] * m[1][0];
  const float s = linear_determinant(t) < 0 ? -1.0f : 1.0f;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[r][c] *= s;
}

}  // namespace

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

  std::vector<Transform> instances = in.instances;
  if (instances.empty()) instances.emplace_back();
  for (size_t i = 0; i < instances.size(); ++i) {
    const Transform& tr = instances[i];
    const std::string name = in.instance_names.empty() ? in.name : in.instance_names[i];
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(tr.m[r][c]))
          throw SceneError(fmt::format("{}: object '{}': the matrix is not finite (row {}, column {} is {})", source_, name, r,
                                       c, tr.m[r][c]));
    if (tr.m[3][0] != 0 || tr.m[3][1] != 0 || tr.m[3][2] != 0 || tr.m[3][3] != 1)
      throw SceneError(fmt::format("{}: object '{}': the matrix is not affine (last row must be 0 0 0 1)", source_, name));
    if (linear_determinant(tr) == 0)
      throw SceneError(fmt::format("{}: object '{}': the matrix is singular (zero scale?)", source_, name));
    Pending p;
    p.materials = in.materials;
    Mesh& m = p.mesh;
    m.name = name;
    m.positions.resize(nv);
    if (in.normals) m.normals.resize(nv);
    float nm[3][3];
    normal_matrix(tr, nm);
    parallel_for(nv, 0, [&](size_t begin, size_t end) {
      for (size_t v = begin; v != end; ++v) {
        const float* q = in.positions + 3 * v;
        m.positions[v] = tr.point(Vec3(q[0], q[1], q[2]));
        if (in.normals) {
          const float* n = in.normals + 3 * v;
          const Vec3 w{nm[0][0] * n[0] + nm[0][1] * n[1] + nm[0][2] * n[2],
                       nm[1][0] * n[0] + nm[1][1] * n[1] + nm[1][2] * n[2],
                       nm[2][0] * n[0] + nm[2][1] * n[1] + nm[2][2] * n[2]};
          const float len = length(w);
          m.normals[v] = len > 0 && std::isfinite(len) ? w / len : Vec3(0, 0, 1);
        }
      }
    });
    if (in.uvs) {
      m.uvs.resize(nv);
      for (size_t v = 0; v < nv; ++v) m.uvs[v] = Vec2(in.uvs[2 * v], in.uvs[2 * v + 1]);
    }
    m.indices.assign(in.indices, in.indices + 3 * nt);
    // A mirroring matrix reverses the winding so geometric normals keep their side (as the loader).
    if (linear_determinant(tr) < 0)
      for (size_t k = 0; k < 3 * nt; k += 3) std::swap(m.indices[k + 1], m.indices[k + 2]);
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

}  // namespace gp
