"""Fluid (smoke/fire) domains: a baked gas domain's OpenVDB cache -> a grid medium of the core
inside the domain's box, as Volume objects are exported (export/volume_object.py).

Blender 3.4 bakes a gas domain's grids into cache_directory/data/fluid_data_NNNN.vdb (frame
NNNN; Cache > Format OpenVDB, the default). Cycles 3.4 (intern/cycles/blender/volume.cpp,
sync_smoke_volume / BlenderSmokeLoader) reads the same simulation through the domain's RNA grids
and maps the grid of the domain's resolution onto the domain mesh's texture space (its
bounding box), so this maps the file's index space [0, resolution] onto that box, whatever
transform the file's grids carry, then through the object's matrix. The Principled Volume's
attributes name grids as Cycles' standard attributes do (rna_fluid.c's grids, which Cycles'
BlenderSmokeLoader reads): "density" and "flame" are the file's grids of those names; "color" is
the file's color_r / color_g / color_b times its density, unpremultiplied after interpolation
(manta_smoke_get_rgba; the scene format's smoke_color_grids); "temperature" is the file's flame
mapped voxel by voxel to ignition + flame x (maximum - ignition) where the flame exceeds 0.01,
else 0 (rna_FluidModifier_temperature_grid_get; the scene format's flame_temperature). (The
file's own "temperature" grid is the simulation's heat, not Cycles' temperature.) An attribute
the file does not hold as Cycles reads it ("heat", "velocity", "color" of a domain without
colour grids) is one warning naming the domain, and the rest renders; "temperature" without a
flame grid is 0 in Cycles, so blackbody emission is then nothing, as there. A domain not baked (no file for the frame), a cache in another format, an
adaptive domain or one with noise (a higher resolution cache) is one warning naming the object,
and the domain is not rendered.
"""
import os

import bpy
import numpy as np

from .. import native
from . import mesh, volume

# The file's grids that are Cycles' standard attributes of the same name on a smoke domain.
_SAME_AS_CYCLES = ("density", "flame")
# Attributes Cycles finds on a smoke domain that the file does not hold as Cycles reads them.
_NOT_IN_FILE = ("heat", "velocity")
_COLOR_GRIDS = ("color_r", "color_g", "color_b", "density")


def _attribute_map(by_name, ds):
    """Cycles' standard attributes of a smoke domain -> the scene format's keys that give them
    from the cache file (export/volume.py _grid_of reads this)."""
    m = {n: {"grid": n} for n in _SAME_AS_CYCLES if n in by_name}
    if all(n in by_name for n in _COLOR_GRIDS):
        m["color"] = {"smoke_color_grids": list(_COLOR_GRIDS)}
    if "flame" in by_name:
        m["temperature"] = {"grid": "flame",
                            "flame_temperature": [float(ds.flame_ignition), float(ds.flame_max_temp)]}
    else:
        m["temperature"] = {"zero": True}  # Cycles' temperature grid is all 0 without fire
    return m


def gas_domain(ob):
    """The Fluid modifier's domain settings of a smoke (gas) domain shown in renders, else None."""
    for md in getattr(ob, "modifiers", ()):
        if md.type == 'FLUID' and md.fluid_type == 'DOMAIN' and md.show_render:
            ds = md.domain_settings
            if ds is not None and ds.domain_type == 'GAS':
                return ds
    return None


def cache_file(ds, frame):
    """The OpenVDB file a baked domain holds for `frame`, absolute."""
    base = bpy.path.abspath(ds.cache_directory)
    return os.path.join(base, "data", f"fluid_data_{frame:04d}.vdb")


def _texspace_box(ob_eval):
    """(lo, hi) of the domain mesh's texture space in object space (its bounding box when Auto
    Texture Space is on, as for a domain)."""
    me = ob_eval.data
    loc = np.array(me.texspace_location, dtype=np.float64)
    size = np.array(me.texspace_size, dtype=np.float64)
    return loc - size, loc + size


def add_smoke_domain(out, inst, mats, media, warnings, frame):
    """Exports gas domain instance `inst` (its Fluid modifier's domain): its medium (into
    `media`), a boundary material and a box mesh record (into out.meshes). True when exported
    (or warned about): the domain's mesh is then not exported as a surface."""
    ob = inst.object
    ds = gas_domain(ob)
    if ds is None:
        return False
    if ds.cache_data_format != 'OPENVDB':
        warnings.add("fluid domain cache is not OpenVDB (not rendered)", f"{ob.name}: {ds.cache_data_format}")
        return True
    if ds.use_adaptive_domain or ds.use_noise:
        warnings.add("fluid domain with adaptive domain or noise not rendered", ob.name)
        return True
    path = cache_file(ds, frame)
    if not os.path.isfile(path):
        warnings.add("fluid domain not baked (not rendered)", f"{ob.name}: no cache file '{path}'")
        return True
    try:
        grids = native.get().vdb_grids(path)
    except (ValueError, RuntimeError) as e:
        warnings.add("fluid domain cache not readable (not rendered)", f"{ob.name}: {e}")
        return True
    by_name = {g["name"]: g for g in grids}
    res = np.array(ds.domain_resolution, dtype=np.float64)
    if "density" not in by_name or not (res > 0).all():
        warnings.add("fluid domain cache has no density grid (not rendered)", f"{ob.name}: '{path}'")
        return True
    # Index space [0, res] -> the texture-space box (Cycles' mapping), written as the grid's
    # object-to-world transform composed with the inverse of the file's own index-to-object.
    lo, hi = _texspace_box(ob)
    target = np.eye(4)
    target[:3, :3] = np.diag((hi - lo) / res)
    target[:3, 3] = lo
    file_i2o = np.asarray(by_name["density"]["index_to_object"], dtype=np.float64)
    try:
        to_object = target @ np.linalg.inv(file_i2o)
    except np.linalg.LinAlgError:
        warnings.add("fluid domain cache not readable (not rendered)", f"{ob.name}: singular grid transform")
        return True
    matrix = (np.array(inst.matrix_world, dtype=np.float64) @ to_object).astype(np.float32)

    mat = ob.active_material
    owner = f"fluid domain '{ob.name}'" + (f", material '{mat.name}'" if mat is not None else "")
    socket = None
    if mat is not None and mat.use_nodes:
        socket = volume.volume_socket(mat.node_tree, 'ShaderNodeOutputMaterial')
    if socket is None and mat is not None:
        return True  # a material without a Volume output: nothing (Cycles renders no volume)
    info = {"file": path, "map": _attribute_map(by_name, ds), "transform": {"matrix": matrix.reshape(16).tolist()}}
    medium = volume.export_volume(socket, owner, warnings, keep_empty=True, grids=info)
    if mat is not None and mat.use_nodes:
        for node in mat.node_tree.nodes:
            if node.bl_idname != 'ShaderNodeVolumePrincipled':
                continue
            for socket_name in ("Density Attribute", "Color Attribute", "Temperature Attribute"):
                attr = node.inputs[socket_name].default_value
                used = socket_name != "Temperature Attribute" or node.inputs["Blackbody Intensity"].default_value > 0
                if used and (attr in _NOT_IN_FILE or (attr == "color" and "color" not in info["map"])):
                    warnings.add("fluid domain attribute not rendered", f"{owner}: '{attr}'")
    name = f"{ob.name} [smoke]" if mat is None else f"{ob.name} [{mat.name}]"
    media[name] = medium
    mats.table[name] = {"type": "volume", "interior": name}
    # The boundary: the texture-space box in object space, through the object's matrix.
    rec = mesh.MeshRecord(name)
    corners = np.array([[hi[0] if c & 1 else lo[0], hi[1] if c & 2 else lo[1], hi[2] if c & 4 else lo[2]]
                        for c in range(8)], dtype=np.float32)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = []
    for a, b, c, d in quads:
        tris += [(a, b, c), (a, c, d)]
    rec.positions = corners
    rec.indices = np.array(tris, dtype=np.uint32)
    rec.triangle_count = len(rec.indices)
    rec.materials = [name]
    rec.matrices = [np.array(inst.matrix_world, dtype=np.float32)]
    rec.instance_names = [ob.name]
    out.meshes.append(rec)
    return True
