"""Blender -> gradphoton scene: the one layer that reads Blender data (BlendLuxCore's split:
mesh, material, light, camera, world). The result, ExportedScene, is plain data: a JSON-style
description of the small parts (docs/scene-format.md, so units are the core's) and numpy
arrays for meshes. It becomes a native Scene through SceneBuilder, or a JSON scene file.
"""
import json
import time

import numpy as np

from . import camera, light, material, mesh, skipped, visibility, world
from .warnings import Warnings

__all__ = ["ExportedScene", "export_scene", "Warnings"]


class ExportedScene:
    def __init__(self):
        self.description = {"materials": {}, "lights": []}
        self.meshes = []          # mesh.MeshRecord
        self.warnings = Warnings()
        self.width = self.height = 0
        self.border = None        # (x0, y0, w, h) in pixels, Blender's bottom-left origin, or None
        self.seconds = 0.0        # export time
        self.name = "scene"

    @property
    def triangle_count(self):
        return sum(m.triangle_count * max(1, len(m.matrices)) for m in self.meshes)

    def build(self, native_module):
        """A finalized native Scene (raises the module's SceneError naming the object)."""
        b = native_module.SceneBuilder(f"Blender scene '{self.name}'")
        b.set_description(json.dumps(self.description))
        for m in self.meshes:
            b.add_mesh(m.name, m.positions, m.indices, m.materials, material_ids=m.material_ids,
                       normals=m.normals, uvs=m.uvs, matrices=np.stack(m.matrices), instance_names=m.instance_names,
                       attributes=m.attributes, default_color=m.default_color)
        return b.finalize()

    def to_json(self):
        """The scene as a scene-format dict: each instance an inline mesh with a matrix."""
        out = dict(self.description)
        objects = []
        for m in self.meshes:
            for matrix, name in zip(m.matrices, m.instance_names):
                o = {"name": name, "type": "mesh", "positions": m.positions.tolist(),
                     "indices": m.indices.tolist(), "transform": {"matrix": matrix.reshape(16).tolist()}}
                if m.normals is not None:
                    o["normals"] = m.normals.tolist()
                if m.uvs is not None:
                    o["uvs"] = m.uvs.tolist()
                if m.attributes:
                    o["attributes"] = {n: {"domain": d, "values": v.tolist()} for n, d, v in m.attributes}
                if m.material_ids is None or len(m.materials) == 1:
                    o["material"] = m.materials[0]
                else:
                    o["materials"] = m.materials
                    o["material_indices"] = m.material_ids.tolist()
                objects.append(o)
        out["objects"] = objects
        return out


def export_scene(depsgraph, *, export_uvs=False, mesh_cache=None, method=None):
    """Exports the evaluated depsgraph (visible objects and instances, modifiers applied); mesh
    arrays come from `mesh_cache` (mesh.MeshCache) where it holds them. `method` (default: the
    scene's) is the one that will render it, for the warnings about what it ignores."""
    t0 = time.perf_counter()
    if mesh_cache is not None:
        mesh_cache.hits = mesh_cache.misses = 0
    scene = depsgraph.scene
    out = ExportedScene()
    out.name = scene.name
    w = out.warnings
    media = {}
    mats = material.MaterialExporter(out.description["materials"], w, media)
    meshes = {}
    lights = out.description["lights"]
    for inst in depsgraph.object_instances:
        ob = inst.object
        if inst.is_instance and not inst.show_self:
            continue
        kind = ob.type
        skipped.check_object(ob, kind, w)
        if kind in mesh.GEOMETRY_TYPES:
            mesh.add_instance(meshes, inst, mats, w, export_uvs, mesh_cache)
        elif kind == 'LIGHT':
            light.add_light(out, inst, mats, w)
        # cameras, empties, armatures: nothing to render
    if mesh_cache is not None:
        mesh_cache.keep_only(meshes.keys())
    out.meshes = [m for m in meshes.values() if m.triangle_count > 0] + out.meshes  # area lights first added
    skipped.check_scene(scene, mats.used_materials(), w)
    out.description["camera"], out.width, out.height, out.border = camera.export_camera(scene, w)
    settings = getattr(scene, "gradphoton", None)
    env = world.export_world(scene.world, w)
    if env:
        out.description["environment"] = env
    world_medium = world.export_world_volume(scene.world, w)
    if world_medium is not None:
        media[world.WORLD_MEDIUM] = world_medium
        out.description["world_medium"] = world.WORLD_MEDIUM
    if media:
        out.description["media"] = media
    visibility.check_method(out.description, method or (settings.method if settings else "pt"), w)
    out.seconds = time.perf_counter() - t0
    return out
