#include "scene/obj_mesh.h"

#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>
#include <vector>

namespace gp {

namespace {

// Gives tinyobjloader the usemtl names found in the OBJ text as if an .mtl had defined them,
// so faces keep their material names; .mtl contents are not used (materials come from the
// scene file).
class UsemtlNames : public tinyobj::MaterialReader {
 public:
  explicit UsemtlNames(std::vector<std::string> names) : names_(std::move(names)) {}
  bool operator()(const std::string&, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* map, std::string*, std::string*) override {
    for (const std::string& n : names_)
      if (map->find(n) == map->end()) {
        tinyobj::material_t m{};  // value-initialized: its texture options have no initializers (UBSan)
        m.name = n;
        map->emplace(n, static_cast<int>(materials->size()));
        materials->push_back(m);
      }
    return true;
  }

 private:
  std::vector<std::string> names_;
};

constexpr const char* kUsemtlMtllib = "__gradphoton_usemtl_names__";

}  // namespace

Mesh read_obj_mesh(const JsonReader& r, const std::filesystem::path& file, const std::string& path,
                   const std::string& fpath, const std::string& name, const ObjMaterials& materials,
                   Warnings& warnings) {
  std::ifstream in(file, std::ios::binary);
  if (!in) r.fail(fpath, fmt::format("cannot open OBJ file '{}' ({})", file.string(), std::strerror(errno)));
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();

  // usemtl names, so that faces keep them (see UsemtlNames).
  std::vector<std::string> usemtl;
  {
    std::istringstream lines(text);
    std::string line;
    while (std::getline(lines, line)) {
      std::istringstream words(line);
      std::string w, n;
      if (words >> w && w == "usemtl" && words >> n && std::find(usemtl.begin(), usemtl.end(), n) == usemtl.end())
        usemtl.push_back(n);
    }
  }
  std::istringstream stream(std::string("mtllib ") + kUsemtlMtllib + "\n" + text);
  UsemtlNames reader(usemtl);
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> obj_materials;
  std::string warn, err;
  const bool ok = tinyobj::LoadObj(&attrib, &shapes, &obj_materials, &warn, &err, &stream, &reader, true, false);
  if (!ok || !err.empty()) r.fail(fpath, fmt::format("OBJ file '{}': {}", file.string(), err.empty() ? "cannot be parsed" : err));

  // OBJ material id -> scene material (resolved once per name).
  std::vector<std::optional<uint32_t>> resolved(obj_materials.size());
  for (size_t i = 0; i < obj_materials.size(); ++i) {
    resolved[i] = materials.by_name(obj_materials[i].name);
  }

  const size_t nv = attrib.vertices.size() / 3, nn = attrib.normals.size() / 3, nt = attrib.texcoords.size() / 2;
  bool all_normals = true, all_uvs = true;
  for (const auto& s : shapes)
    for (const auto& ix : s.mesh.indices) {
      all_normals = all_normals && ix.normal_index >= 0;
      all_uvs = all_uvs && ix.texcoord_index >= 0;
    }
  struct Key {
    int v, n, t;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return std::hash<int64_t>()((int64_t(k.v) * 1000003 + k.n) * 1000003 + k.t);
    }
  };
  std::unordered_map<Key, uint32_t, KeyHash> vertex_of;
  std::vector<std::string> warned_names;
  Mesh mesh;
  size_t face_number = 0;
  for (const auto& s : shapes) {
    size_t offset = 0;
    for (size_t f = 0; f < s.mesh.num_face_vertices.size(); ++f, ++face_number) {
      const size_t fv = s.mesh.num_face_vertices[f];
      if (fv != 3) r.fail(fpath, fmt::format("OBJ file '{}': face {} has {} vertices after triangulation", file.string(), face_number, fv));
      for (size_t k = 0; k < 3; ++k) {
        const tinyobj::index_t ix = s.mesh.indices[offset + k];
        if (ix.vertex_index < 0 || static_cast<size_t>(ix.vertex_index) >= nv)
          r.fail(fpath, fmt::format("OBJ file '{}': face {} of '{}' uses vertex {} but the file has {} vertices",
                                  file.string(), face_number, name, ix.vertex_index + 1, nv));
        if (all_normals && static_cast<size_t>(ix.normal_index) >= nn)
          r.fail(fpath, fmt::format("OBJ file '{}': face {} uses normal {} but the file has {} normals", file.string(),
                                  face_number, ix.normal_index + 1, nn));
        if (all_uvs && static_cast<size_t>(ix.texcoord_index) >= nt)
          r.fail(fpath, fmt::format("OBJ file '{}': face {} uses texture coordinate {} but the file has {}",
                                  file.string(), face_number, ix.texcoord_index + 1, nt));
        const Key key{ix.vertex_index, all_normals ? ix.normal_index : -1, all_uvs ? ix.texcoord_index : -1};
        auto [it, inserted] = vertex_of.try_emplace(key, static_cast<uint32_t>(mesh.positions.size()));
        if (inserted) {
          const float* p = &attrib.vertices[3 * key.v];
          const Vec3 position{p[0], p[1], p[2]};
          if (!is_finite(position))
            r.fail(fpath, fmt::format("OBJ file '{}': vertex {} is not finite", file.string(), key.v + 1));
          mesh.positions.push_back(position);
          if (all_normals) {
            const float* n = &attrib.normals[3 * key.n];
            const Vec3 normal{n[0], n[1], n[2]};
            const float len = length(normal);
            mesh.normals.push_back(len > 0 && std::isfinite(len) ? normal / len : normal);
          }
          if (all_uvs) mesh.uvs.push_back(Vec2(attrib.texcoords[2 * key.t], attrib.texcoords[2 * key.t + 1]));
        }
        mesh.indices.push_back(it->second);
      }
      offset += fv;
      const int id = f < s.mesh.material_ids.size() ? s.mesh.material_ids[f] : -1;
      if (id >= 0 && static_cast<size_t>(id) < resolved.size() && resolved[id]) {
        mesh.material_ids.push_back(*resolved[id]);
        continue;
      }
      const bool named = id >= 0 && static_cast<size_t>(id) < obj_materials.size();
      if (!materials.fallback) {
        if (named)
          r.fail(fpath, fmt::format("OBJ file '{}': usemtl '{}' is not a scene material (known: {}) and the object has "
                                  "no materials.fallback 'material'", file.string(), obj_materials[id].name, materials.known));
        r.fail(path, fmt::format("OBJ file '{}' has faces without usemtl; give the object a 'material'", file.string()));
      }
      if (named && std::find(warned_names.begin(), warned_names.end(), obj_materials[id].name) == warned_names.end()) {
        warned_names.push_back(obj_materials[id].name);
        warnings.add("obj material not in scene",
                            fmt::format("{}: {}: usemtl '{}' in '{}' uses the materials.fallback material", r.file(), fpath,
                                        obj_materials[id].name, file.string()));
      }
      mesh.material_ids.push_back(*materials.fallback);
    }
  }
  {
    // Faces tinyobjloader could not triangulate because of bad indices are dropped with a
    // warning; that is an error here, like a bad index in a triangle above.
    std::istringstream lines(warn);
    std::string line;
    while (std::getline(lines, line)) {
      if (line.empty()) continue;
      if (line.find("out of bounds") != std::string::npos) r.fail(fpath, fmt::format("OBJ file '{}': {}", file.string(), line));
      warnings.add("obj warning", fmt::format("{}: {}: {}", r.file(), file.string(), line));
    }
  }
  if (mesh.indices.empty()) warnings.add("empty object", fmt::format("{}: {}: '{}' has no faces", r.file(), fpath, file.string()));
  return mesh;
}

}  // namespace gp
