"""Keeping one native scene in step with Blender between renders: the rendered viewport (every
edit) and Persistent Data (every frame of an animation), as Cycles' BlenderSync does.

Each sync exports the depsgraph again, but mesh arrays come from a cache (export/mesh.py
MeshCache): only objects whose geometry changed (depsgraph.updates' is_updated_geometry) are
read from Blender again. The export is then compared with the previous one:

  - the same meshes (same arrays, materials and instance count): an Update with the native
    meshes whose matrix changed (Scene.set_transforms: transformed again natively, only their
    part of the BVH rebuilt) and the description (materials, lights, world) when it changed
    (Scene.update_description), and the camera when it changed (Scene.set_camera);
  - anything else (a new object, changed geometry, another material slot): a rebuild of the
    native scene from the arrays, cached ones included (no Blender data read for them).

Plain data in, plain data out: nothing here holds a Blender object between syncs, so the plan
can be applied on another thread (viewport.py's worker) while Blender goes on.
"""
import json

import bpy
import numpy as np

from . import export
from .export.mesh import GEOMETRY_TYPES, MeshCache


class Plan:
    """What one sync asks of the native scene. `rebuild`: an ExportedScene to build from (then
    nothing else applies); else `transforms` ([native mesh index], (K,4,4) float32),
    `description` (JSON text or None), `camera` (JSON text or None)."""

    def __init__(self, rebuild=None, transforms=None, description=None, camera=None, reason="", exported=None):
        self.rebuild = rebuild
        self.exported = exported or rebuild  # the export this plan brings the scene to (a rebuild's fallback)
        self.transforms = transforms
        self.description = description
        self.camera = camera
        self.reason = reason  # why a rebuild (tests, the status line)

    @property
    def empty(self):
        return self.rebuild is None and not self.transforms and self.description is None and self.camera is None

    def kinds(self):
        if self.rebuild is not None:
            return ["rebuild"]
        return [k for k, v in (("transforms", self.transforms), ("description", self.description),
                               ("camera", self.camera)) if v]

    def merged(self, later):
        """This plan followed by `later`, as one (a worker applies what piled up at once)."""
        if later.rebuild is not None:
            return later
        if self.rebuild is not None:
            # `later` is relative to the export after this rebuild: fold it in.
            return Plan(rebuild=self.rebuild, reason=self.reason, camera=later.camera or self.camera,
                        description=later.description or self.description,
                        transforms=_merge_transforms(self.transforms, later.transforms), exported=later.exported)
        return Plan(transforms=_merge_transforms(self.transforms, later.transforms),
                    description=later.description if later.description is not None else self.description,
                    camera=later.camera if later.camera is not None else self.camera, exported=later.exported)


def _merge_transforms(a, b):
    if not a:
        return b
    if not b:
        return a
    out = dict(zip(a[0], a[1]))
    out.update(zip(b[0], b[1]))
    keys = sorted(out)
    return keys, np.stack([out[k] for k in keys]).astype(np.float32)


def geometry_updates(depsgraph):
    """Names of objects whose geometry changed since the previous evaluation, and whether
    anything else needs the description exported again (always cheap, so: any update)."""
    names = set()
    for u in depsgraph.updates:
        idb = u.id
        if isinstance(idb, bpy.types.Object):
            if u.is_updated_geometry and idb.type in GEOMETRY_TYPES:
                names.add(idb.name)
        elif u.is_updated_geometry and getattr(idb, "users", 0):
            # A mesh, curve, ... datablock: every object that shows it.
            for ob in depsgraph.objects:
                if ob.data is not None and ob.data.original == idb.original:
                    names.add(ob.name)
    return names


def _layout(exported):
    """What must match for an update instead of a rebuild: per record its arrays, materials and
    instance count (native meshes are the records' instances in this order)."""
    out = []
    for m in exported.meshes:
        if m.geometry_id is not None:
            gid = m.geometry_id
        else:  # an area light's quad or disk (export/light.py): tiny, compared by value
            gid = (m.positions.tobytes(), m.indices.tobytes())
        out.append((gid, tuple(m.materials), len(m.matrices)))
    return out


def _description_text(exported):
    d = {k: v for k, v in exported.description.items() if k != "camera"}
    d.setdefault("environment", None)
    if d["environment"] is None:
        d.pop("environment")
    return json.dumps(d, sort_keys=True)


class SceneSync:
    """The previous export and the mesh cache of one native scene."""

    def __init__(self):
        self.cache = MeshCache()
        self.layout = None
        self.matrices = None      # (N, 4, 4) float32 per native mesh
        self.description = None   # JSON text without the camera
        self.camera = None        # JSON text of the camera
        self.exported = None
        self.had_motion = False   # the previous export moved something (motion blur)

    def reset(self):
        self.__init__()

    def sync(self, depsgraph, *, export_uvs=False, first=False, camera=None, frame_set=None):
        """A Plan for the depsgraph's current state. `first`: a fresh evaluation (a new viewport
        or a render without persistent data): everything is read again. `camera`: a camera
        JSON-able dict that replaces the exported one (the viewport's view). `frame_set`: motion
        blur (a render with Persistent Data; export.export_scene), never in the viewport."""
        if first:
            self.reset()
        else:
            self.cache.drop(geometry_updates(depsgraph))
        exported = export.export_scene(depsgraph, export_uvs=export_uvs, mesh_cache=self.cache, frame_set=frame_set)
        if camera is not None:
            exported.description["camera"] = camera
        return self.plan_for(exported)

    def plan_for(self, exported):
        layout = _layout(exported)
        matrices = (np.concatenate([np.stack(m.matrices) for m in exported.meshes]).astype(np.float32)
                    if exported.meshes else np.zeros((0, 4, 4), np.float32))
        description = _description_text(exported)
        camera = json.dumps(exported.description.get("camera"), sort_keys=True)
        if self.layout is None or layout != self.layout or exported.has_motion or self.had_motion:
            # Motion (or its end) has no in-place update: Scene.set_transforms takes one matrix.
            reason = ("first export" if self.layout is None else "objects or geometry changed"
                      if layout != self.layout else "motion blur")
            plan = Plan(rebuild=exported, reason=reason)
        else:
            changed = np.nonzero(np.any(matrices != self.matrices, axis=(1, 2)))[0]
            plan = Plan(transforms=(changed.tolist(), matrices[changed]) if len(changed) else None,
                        description=description if description != self.description else None,
                        camera=camera if camera != self.camera else None, exported=exported)
        self.layout, self.matrices, self.description, self.camera = layout, matrices, description, camera
        self.exported = exported
        self.had_motion = exported.has_motion
        return plan


def apply(plan, scene, native_module):
    """Applies `plan` to the native `scene` (None for a rebuild) and returns the scene to render:
    the same one updated, or a new one. A description update the scene cannot take (a material
    an object uses is gone) raises the module's SceneError (a ValueError): the caller rebuilds
    (the sync's export, plan.rebuild or sync.exported). Releases the GIL in the native calls."""
    if plan.rebuild is not None or scene is None:
        scene = plan.rebuild.build(native_module)  # the updates below are folded in after its export
    if plan.transforms:
        scene.set_transforms(plan.transforms[0], plan.transforms[1])
    if plan.description is not None:
        scene.update_description(plan.description)
    if plan.camera is not None:
        scene.set_camera(plan.camera)
    return scene
