"""Blender -> gradphoton scene: the one layer that reads Blender data (BlendLuxCore's split:
mesh, material, light, camera, world). The result, ExportedScene, is plain data: a JSON-style
description of the small parts (docs/scene-format.md, so units are the core's) and numpy
arrays for meshes. It becomes a native Scene through SceneBuilder, or a JSON scene file.
"""
import json
import time

import numpy as np

from . import camera, fluid, light, material, mesh, motion, skipped, visibility, volume_object, world
from .warnings import Warnings

__all__ = ["ExportedScene", "export_scene", "scene_frame_set", "Warnings"]


def scene_frame_set(depsgraph):
    """frame_set for export_scene outside a render (Export Scene, tests): the scene's own
    Scene.frame_set, which evaluates the view layer's depsgraph (the one given)."""
    scene = depsgraph.scene.original

    def frame_set(frame, subframe):
        scene.frame_set(frame, subframe=subframe)
    return frame_set


class ExportedScene:
    def __init__(self):
        self.description = {"materials": {}, "lights": []}
        self.meshes = []          # mesh.MeshRecord
        self.warnings = Warnings()
        self.width = self.height = 0
        self.border = None        # (x0, y0, w, h) in pixels, Blender's bottom-left origin, or None
        self.seconds = 0.0        # export time
        self.name = "scene"
        self.moving = []          # names of what moves over the shutter (export/motion.py), or []

    @property
    def has_motion(self):
        return bool(self.moving)

    @property
    def triangle_count(self):
        return sum(m.triangle_count * max(1, len(m.matrices)) for m in self.meshes)

    def build(self, native_module):
        """A finalized native Scene (raises the module's SceneError naming the object)."""
        b = native_module.SceneBuilder(f"Blender scene '{self.name}'")
        b.set_description(json.dumps(self.description))
        for m in self.meshes:
            # Motion only where there is some: a static scene calls the builder as before.
            extra = {}
            if m.motion is not None:
                extra["motion"] = m.motion
            if m.motion_positions is not None:
                extra["motion_positions"] = m.motion_positions
            b.add_mesh(m.name, m.positions, m.indices, m.materials, material_ids=m.material_ids,
                       normals=m.normals, uvs=m.uvs, matrices=np.stack(m.matrices), instance_names=m.instance_names,
                       attributes=m.attributes, default_color=m.default_color,
                       instance_random_ids=m.instance_random_ids, **extra)
        return b.finalize()

    def to_json(self):
        """The scene as a scene-format dict: each instance an inline mesh with a matrix."""
        out = dict(self.description)
        objects = []
        for m in self.meshes:
            for k, (matrix, name) in enumerate(zip(m.matrices, m.instance_names)):
                o = {"name": name, "type": "mesh", "positions": m.positions.tolist(), "indices": m.indices.tolist()}
                rid = m.instance_random_ids[k] if k < len(m.instance_random_ids) else None
                if rid is not None:
                    o["random_id"] = rid
                steps = m.motion[k] if m.motion is not None else None
                if steps is not None and not (steps == steps[0]).all():
                    o["motion"] = [{"matrix": t.reshape(16).tolist()} for t in steps]
                else:
                    o["transform"] = {"matrix": matrix.reshape(16).tolist()}
                if m.motion_positions is not None:
                    o["motion_positions"] = m.motion_positions.reshape(len(m.motion_positions), -1).tolist()
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


def export_scene(depsgraph, *, export_uvs=False, mesh_cache=None, method=None, frame_set=None):
    """Exports the evaluated depsgraph (visible objects and instances, modifiers applied); mesh
    arrays come from `mesh_cache` (mesh.MeshCache) where it holds them. `method` (default: the
    scene's) is the one that will render it, for the warnings about what it ignores.
    `frame_set(frame, subframe)` evaluates the depsgraph at another time (RenderEngine.frame_set
    in a render, scene_frame_set otherwise): given, and with Render > Motion Blur on, objects and
    the camera are sampled over the shutter as Cycles does (export/motion.py) and the frame is
    restored; without it (the viewport) nothing blurs, as in Cycles' viewport."""
    t0 = time.perf_counter()
    if mesh_cache is not None:
        mesh_cache.hits = mesh_cache.misses = 0
    scene = depsgraph.scene
    out = ExportedScene()
    out.name = scene.name
    w = out.warnings
    shutter = motion.scene_shutter(scene, depsgraph.view_layer, w) if frame_set is not None else None
    sampler = motion.MotionSampler(shutter, frame_set, scene) if shutter is not None else None
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
        if kind == 'MESH' and fluid.gas_domain(ob) is not None:
            # A smoke domain: its baked grids, not its mesh (export/fluid.py).
            fluid.add_smoke_domain(out, inst, mats, media, w, scene.frame_current)
        elif kind in mesh.GEOMETRY_TYPES:
            mesh.add_instance(meshes, inst, mats, w, export_uvs, mesh_cache, sampler,
                              view_layer=depsgraph.view_layer_eval)
        elif kind == 'LIGHT':
            added = light.add_light(out, inst, mats, w)
            # Cycles 3.4 does not blur lights: they move only when Blur Moving Lights asks.
            if sampler is not None and added is not None and getattr(getattr(scene, "gradphoton", None), "motion_blur_lights", False):
                sampler.add_light(inst, np.array(inst.matrix_world, dtype=np.float32), added)
        elif kind == 'VOLUME':
            volume_object.add_volume_object(out, inst, mats, media, w)
        # cameras, empties, armatures: nothing to render
    if mesh_cache is not None:
        mesh_cache.keep_only(meshes.keys())
    out.meshes = [m for m in meshes.values() if m.triangle_count > 0] + out.meshes  # area lights first added
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
        # Light Paths > Volume bounces, as Cycles reads it (0: single scattering; the core's
        # camera path and photon walk, docs/scene-format.md).
        cycles = getattr(scene, "cycles", None)
        if cycles is not None:
            out.description["volume_bounces"] = int(cycles.volume_bounces)
    # Light Paths > Max Bounces > Transparent: the transparent surfaces a shadow ray may cross
    # (Cycles' transparent_max_bounces; the core's default is Cycles' 8, docs/scene-format.md).
    cycles = getattr(scene, "cycles", None)
    if cycles is not None and hasattr(cycles, "transparent_max_bounces"):
        out.description["transparent_bounces"] = int(cycles.transparent_max_bounces)
    # Light Paths > Caustics (Cycles' blur_glossy, caustics_reflective, caustics_refractive;
    # Cycles' defaults 1.0 / on / on): honoured by pt, spt and spt-hero as Cycles does, said by the
    # other methods (the core's feature_report). Without the Cycles add-on the core's defaults
    # (nothing filtered) hold.
    if cycles is not None and hasattr(cycles, "blur_glossy"):
        out.description["filter_glossy"] = float(cycles.blur_glossy)
        out.description["caustics_reflective"] = bool(cycles.caustics_reflective)
        out.description["caustics_refractive"] = bool(cycles.caustics_refractive)
    method = method or (settings.method if settings else "pt")
    visibility.check_method(out.description, method, w)
    if sampler is not None:  # last: every other read is of the frame itself
        sampler.add_camera(scene.camera, out.description["camera"].get("matrix"))
        sampler.sample(depsgraph, mesh.evaluated_positions, camera.camera_matrix)
        out.meshes, out.moving = sampler.apply(out.meshes, out.description, w)
        # A method that does not blur says so itself (the core's feature_report, from its declaration).
    out.seconds = time.perf_counter() - t0
    return out
