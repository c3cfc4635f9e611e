"""Volume objects: a .vdb file's grids (the frame's file of a sequence, as Blender resolves it)
under the object's material -> a grid medium of the core inside a box around the grids
(docs/scene-format.md, "Participating media"; docs/blender.md, "Volumes").

As Cycles (intern/cycles/blender/volume.cpp): the Principled Volume's Density / Color /
Temperature Attributes name the grids; the grids' own transform and the object's matrix place
them; an object without a material renders with Cycles' default volume (Principled Volume's
defaults over the "density" grid). The boundary is the box of the grids' active voxels (Cycles
builds a tighter mesh of the active leaves: the same where the density is zero outside them).
A file that is missing or unreadable is one warning naming the object and the file; nothing of
it is rendered then.
"""
import os

import bpy
import numpy as np

from .. import native
from . import mesh, volume


def _file_of(vol):
    """The frame's file of a Volume datablock (sequences resolved by Blender), absolute."""
    grids = vol.grids
    try:
        grids.load()
    except Exception:  # noqa: BLE001 - Blender reports its own error message below
        pass
    path = getattr(grids, "frame_filepath", "") or vol.filepath
    return bpy.path.abspath(path, library=vol.library) if path else ""


def _box(grids, names):
    """(positions (8, 3) float32, indices (12, 3) uint32) in object space: the box of the index
    space cells of `names` (all grids when empty), through the grids' transform."""
    chosen = [g for g in grids if g["name"] in names] or grids
    # (Voxel i fills the cell [i, i + 1] of index space, as in Cycles: media/grid.cpp.)
    lo = np.min([np.array(g["lo"]) for g in chosen], axis=0).astype(np.float64)
    hi = np.max([np.array(g["lo"]) + np.array(g["size"]) for g in chosen], axis=0).astype(np.float64)
    m = np.asarray(chosen[0]["index_to_object"], dtype=np.float64)
    corners = np.array([[hi[0] if c & 1 else lo[0], hi[1] if c & 2 else lo[1], hi[2] if c & 4 else lo[2], 1.0]
                        for c in range(8)])
    positions = (corners @ m.T)[:, :3].astype(np.float32)
    # Outward faces in index space; a mirroring transform turns them inward: flip then.
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = []
    for a, b, c, d in quads:
        tris += [(a, b, c), (a, c, d)]
    idx = np.array(tris, dtype=np.uint32)
    if np.linalg.det(m[:3, :3]) < 0:
        idx = idx[:, ::-1].copy()
    return positions, idx


def add_volume_object(out, inst, mats, media, warnings):
    """Exports Volume object instance `inst`: its medium (into `media`), a boundary material and
    a box mesh record (into out.meshes)."""
    ob = inst.object
    vol = ob.data
    path = _file_of(vol)
    if not path or not os.path.isfile(path):
        warnings.add("volume file not found (volume not rendered)", f"{ob.name}: '{path}'")
        return
    try:
        grids = native.get().vdb_grids(path)
    except (ValueError, RuntimeError) as e:
        warnings.add("volume file not readable (volume not rendered)", f"{ob.name}: {e}")
        return
    if not grids:
        warnings.add("volume file has no float or vector grid (volume not rendered)", f"{ob.name}: '{path}'")
        return
    if len(ob.modifiers):
        warnings.add("volume modifiers not applied (the file's grids rendered)", ob.name)
    mat = ob.active_material
    owner = f"volume '{ob.name}'" + (f", material '{mat.name}'" if mat is not None else "")
    socket = None
    if mat is not None and mat.use_nodes:
        socket = volume.volume_socket(mat.node_tree, 'ShaderNodeOutputMaterial')
    matrix = np.array(inst.matrix_world, dtype=np.float32)
    info = {"file": path, "names": {g["name"] for g in grids},
            "transform": {"matrix": matrix.reshape(16).tolist()}}
    if socket is None and mat is not None:
        return  # a material without a Volume output: nothing (Cycles renders no volume)
    medium = volume.export_volume(socket, owner, warnings, keep_empty=True, grids=info)
    name = f"{ob.name} [volume]" if mat is None else f"{ob.name} [{mat.name}]"
    media[name] = medium
    mats.table[name] = {"type": "volume", "interior": name}
    g = medium.get("grid", {})
    used = {g[k] for k in ("density_grid", "color_grid", "temperature_grid") if k in g}
    rec = mesh.MeshRecord(name)
    rec.positions, rec.indices = _box(grids, used)
    rec.triangle_count = len(rec.indices)
    rec.materials = [name]
    rec.matrices = [matrix]
    rec.instance_names = [ob.name]
    out.meshes.append(rec)
