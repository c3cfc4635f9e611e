"""Meshes: evaluated geometry (modifiers applied) triangulated by Blender's loop triangles and
read with foreach_get into numpy arrays of the exact dtypes the core takes (float32 positions,
uint32 indices), so no Python loop runs per vertex or per triangle.

A mesh is exported per vertex when it is all smooth (vertex normals) or all flat (no normals:
the core shades flat by the triangle normal). Mixed smooth/flat faces, auto smooth and custom
split normals (and UVs: the active render UV map, exported when a material of the object reads
a texture or when asked for) need per-corner data: then every face corner becomes a vertex and
its split normal is used. Instances of one mesh share one record with one matrix per instance.

A MeshCache (the rendered viewport, persistent data: sync.py) keeps the arrays of each record
between exports, so an export after a camera, transform or material change reads no mesh data
from Blender; objects whose geometry changed are dropped from it first (MeshCache.drop).
"""
import numpy as np

from . import visibility

GEOMETRY_TYPES = {'MESH', 'CURVE', 'SURFACE', 'META', 'FONT'}
# Attribute data types Cycles 3.4 renders (blender/mesh.cpp, attr_create_generic), by the
# foreach_get key and component count; byte colours read through `color` arrive scene-linear, as
# Cycles converts them (sRGB to linear per corner, before interpolation).
_ATTRIBUTE_READ = {'FLOAT': ("value", 1), 'FLOAT2': ("vector", 2), 'FLOAT_VECTOR': ("vector", 3),
                   'FLOAT_COLOR': ("color", 4), 'BYTE_COLOR': ("color", 4)}


class MeshRecord:
    def __init__(self, name):
        self.name = name
        self.geometry_id = None  # the arrays' identity (sync.py): same id, same arrays
        self.positions = self.indices = self.normals = self.uvs = self.material_ids = None
        self.attributes = None      # [(name, 'corner' | 'face', float32 array)] or None
        self.default_color = None   # the render colour attribute's name
        self.materials = []
        self.matrices = []
        self.instance_names = []
        # Object Info's Random per instance: Blender's random id of an instanced copy, None for
        # an object itself (the core hashes its name, as Cycles does).
        self.instance_random_ids = []
        self.triangle_count = 0
        # Motion blur (export/motion.py): (K, S, 4, 4) object-to-world matrices of each instance
        # over the shutter, and (S', N, 3) positions of a deforming mesh; None when static.
        self.motion = None
        self.motion_positions = None
        self.deform_source = None  # the object whose deformation is sampled for these arrays
        self.needs_uvs = False

    def copy_without_instances(self):
        """The same arrays and materials with no instances (a record split by motion steps)."""
        c = MeshRecord(self.name)
        c.__dict__.update(self.__dict__)
        c.matrices, c.instance_names, c.instance_random_ids, c.motion = [], [], [], None
        return c


def mesh_arrays(me, export_uvs=False):
    """(positions float32 (N,3), indices uint32 (M,3), normals float32 (N,3) or None,
    uvs float32 (N,2) or None, material_index uint32 (M,)) of a Blender mesh."""
    me.calc_loop_triangles()
    tris = me.loop_triangles
    nt, nv = len(tris), len(me.vertices)
    co = np.empty(nv * 3, np.float32)
    me.vertices.foreach_get("co", co)
    mat = np.empty(nt, np.uint32)
    tris.foreach_get("material_index", mat)
    smooth = np.empty(nt, bool)
    tris.foreach_get("use_smooth", smooth)
    # The UV map Cycles renders with: the one marked for render (the camera icon).
    uv_layer = next((layer for layer in me.uv_layers if layer.active_render), me.uv_layers.active) if export_uvs else None
    # By name: calc_normals_split() below reallocates the loop data, and a layer reference taken
    # before it reads zeros.
    uv_name = uv_layer.name if uv_layer is not None else None
    all_smooth = bool(smooth.all()) if nt else True
    per_corner = (uv_layer is not None or me.has_custom_normals or
                  (me.use_auto_smooth and all_smooth) or not (all_smooth or not smooth.any()))
    if not per_corner:
        idx = np.empty(nt * 3, np.uint32)
        tris.foreach_get("vertices", idx)
        normals = None
        if all_smooth and nt:
            normals = np.empty(nv * 3, np.float32)
            me.vertex_normals.foreach_get("vector", normals)
            normals = normals.reshape(nv, 3)
        return co.reshape(nv, 3), idx.reshape(nt, 3), normals, None, mat
    # Per corner: vertex k of the output is loop k.
    nl = len(me.loops)
    loop_vert = np.empty(nl, np.uint32)
    me.loops.foreach_get("vertex_index", loop_vert)
    idx = np.empty(nt * 3, np.uint32)
    tris.foreach_get("loops", idx)
    me.calc_normals_split()
    normals = np.empty(nl * 3, np.float32)
    me.loops.foreach_get("normal", normals)
    uvs = None
    if uv_name is not None:
        uvs = np.empty(nl * 2, np.float32)
        me.uv_layers[uv_name].data.foreach_get("uv", uvs)
        uvs = uvs.reshape(nl, 2)
    return co.reshape(nv, 3)[loop_vert], idx.reshape(nt, 3), normals.reshape(nl, 3), uvs, mat


def mesh_attributes(me, names, warnings, owner):
    """The attributes a material reads by name (Color Attribute / Attribute nodes; "" is the
    render colour attribute), as [(name, domain, float32 (K,) or (K, c))] over the loop
    triangles: point and corner data per triangle corner (exact: both interpolate linearly over
    a triangle), face data per triangle; UV maps by name as float2 corner data. Also returns the
    render colour's name. Call after mesh_arrays (loop triangles computed)."""
    tris = me.loop_triangles
    nt = len(tris)
    default = me.attributes.default_color_name or None
    wanted = {default if n == "" else n for n in names} - {None}
    out = []
    tri_loops = polys = loop_vert = None
    for name in sorted(wanted):
        a = me.attributes.get(name)
        if a is None:
            if name in me.uv_layers:  # 3.4 keeps UV maps outside the generic attributes
                uv = np.empty(len(me.loops) * 2, np.float32)
                me.uv_layers[name].data.foreach_get("uv", uv)
                if tri_loops is None:
                    tri_loops = np.empty(nt * 3, np.uint32)
                    tris.foreach_get("loops", tri_loops)
                out.append((name, "corner", np.ascontiguousarray(uv.reshape(-1, 2)[tri_loops])))
            continue  # missing: the nodes read Cycles' missing-attribute values
        read = _ATTRIBUTE_READ.get(a.data_type)
        if read is None or a.domain not in ('POINT', 'CORNER', 'FACE'):
            warnings.add(f"attribute '{name}' of type {a.data_type} on {a.domain} is not rendered", owner)
            continue
        key, c = read
        values = np.empty(len(a.data) * c, np.float32)
        a.data.foreach_get(key, values)
        values = values.reshape(-1, c) if c > 1 else values
        if a.domain == 'FACE':
            if polys is None:
                polys = np.empty(nt, np.uint32)
                tris.foreach_get("polygon_index", polys)
            out.append((name, "face", np.ascontiguousarray(values[polys])))
            continue
        if tri_loops is None:
            tri_loops = np.empty(nt * 3, np.uint32)
            tris.foreach_get("loops", tri_loops)
        if a.domain == 'POINT':
            if loop_vert is None:
                loop_vert = np.empty(len(me.loops), np.uint32)
                me.loops.foreach_get("vertex_index", loop_vert)
            values = values[loop_vert]
        out.append((name, "corner", np.ascontiguousarray(values[tri_loops])))
    return out, default


class MeshCache:
    """Arrays of exported meshes by record key, and which objects used each key."""

    def __init__(self):
        self.arrays = {}     # key -> (geometry_id, positions, indices, normals, uvs, material_ids, triangle_count)
        self.attributes = {}  # key -> (attributes, default_color) (MeshRecord's)
        self.users = {}      # object name -> keys it used
        self._next_id = 0
        self.hits = self.misses = 0  # of the latest export (tests, benchmarks)

    def new_id(self):
        self._next_id += 1
        return self._next_id

    def drop(self, object_names):
        """Forgets the arrays every object in `object_names` used (its geometry changed)."""
        for name in object_names:
            for key in self.users.pop(name, ()):
                self.arrays.pop(key, None)
                self.attributes.pop(key, None)

    def keep_only(self, keys):
        """Forgets arrays no record of the latest export used."""
        for key in set(self.arrays) - set(keys):
            del self.arrays[key]
            self.attributes.pop(key, None)
        self.users = {n: k & set(keys) for n, k in self.users.items() if k & set(keys)}


def add_instance(records, inst, mats, warnings, export_uvs, cache=None, motion=None, view_layer=None):
    """Adds one depsgraph instance of a geometry object to `records` (key -> MeshRecord); with a
    MeshCache, a record's arrays come from it when it has them. `motion` (motion.MotionSampler,
    final renders with motion blur on) is told of the instance, to sample it over the shutter.
    `view_layer` (the depsgraph's evaluated one) decides holdouts by collection."""
    ob = inst.object
    matrix = np.array(inst.matrix_world, dtype=np.float32)
    if np.isfinite(matrix).all() and np.linalg.det(matrix[:3, :3].astype(np.float64)) == 0:
        # Zero scale (a common way to hide an object in an animation): nothing to render, as
        # in Cycles. A NaN/Inf matrix still reaches the core, whose error names the object.
        warnings.add("zero scale (left out)", ob.name)
        return
    slots = [s.material for s in ob.material_slots]
    flags = visibility.surface_flags(ob, warnings, visibility.is_held_out(inst, view_layer))
    names = [mats.name_for(m, flags) for m in slots] or [mats.name_for(None, flags)]
    needs_uvs = export_uvs or any(mats.needs_uvs(m) for m in slots)
    attr_names = frozenset().union(*(mats.attributes_read(m) for m in slots))
    data_key = ob.data.as_pointer() if (ob.type == 'MESH' and ob.data is not None) else ob.as_pointer()
    key = (data_key, tuple(names), tuple(sorted(attr_names)))
    rec = records.get(key)
    if cache is not None:
        cache.users.setdefault(ob.name, set()).add(key)
    if rec is None and cache is not None and key in cache.arrays:
        rec = MeshRecord(ob.name)
        (rec.geometry_id, rec.positions, rec.indices, rec.normals, rec.uvs, rec.material_ids,
         rec.triangle_count) = cache.arrays[key]
        rec.attributes, rec.default_color = cache.attributes.get(key, (None, None))
        rec.materials = names
        rec.needs_uvs = needs_uvs
        records[key] = rec
        cache.hits += 1
    if rec is None:
        rec = MeshRecord(ob.name)
        if ob.type == 'MESH':
            me, owner = ob.data, None
        else:
            me, owner = ob.to_mesh(), ob
        try:
            if me is not None and len(me.polygons):
                pos, idx, nrm, uvs, mat = mesh_arrays(me, needs_uvs)
                if needs_uvs and uvs is None and not export_uvs:
                    warnings.add("textured object without a UV map (textures read at uv 0)", ob.name)
                rec.positions, rec.indices, rec.normals, rec.uvs = pos, idx, nrm, uvs
                rec.triangle_count = len(idx)
                if attr_names:
                    rec.attributes, rec.default_color = mesh_attributes(me, attr_names, warnings, ob.name)
                if len(names) > 1:
                    np.minimum(mat, len(names) - 1, out=mat)  # Blender clamps slot indices too
                    rec.material_ids = mat
        finally:
            if owner is not None:
                owner.to_mesh_clear()
        rec.materials = names
        rec.needs_uvs = needs_uvs
        records[key] = rec
        if cache is not None:
            rec.geometry_id = cache.new_id()
            cache.arrays[key] = (rec.geometry_id, rec.positions, rec.indices, rec.normals, rec.uvs, rec.material_ids,
                                 rec.triangle_count)
            cache.attributes[key] = (rec.attributes, rec.default_color)
            cache.misses += 1
    rec.matrices.append(matrix)
    n = len(rec.matrices)
    rec.instance_names.append(ob.name if n == 1 else f"{ob.name} [{n - 1}]")
    rec.instance_random_ids.append(inst.random_id & 0xFFFFFFFF if inst.is_instance else None)
    if motion is not None and rec.triangle_count > 0:
        motion.add_instance(inst, rec, n - 1)


def evaluated_positions(ob, needs_uvs):
    """(positions, indices) of an evaluated geometry object as mesh_arrays lays them out (the
    deformation steps of motion blur: export/motion.py), or None without faces."""
    if ob.type == 'MESH':
        me, owner = ob.data, None
    else:
        me, owner = ob.to_mesh(), ob
    try:
        if me is None or not len(me.polygons):
            return None
        pos, idx, _, _, _ = mesh_arrays(me, needs_uvs)
        return pos, idx
    finally:
        if owner is not None:
            owner.to_mesh_clear()
