"""Build a Blender scene from a gradphoton JSON scene file, so the demo scenes can be rendered
from Blender's UI or with `blender -b file.blend -E GRADPHOTON -f 1`:

    blender -b --factory-startup --python scripts/json_to_blend.py -- scenes/cornell-box.json out/cornell-box.blend

The core loads and tessellates the file (so every shape and OBJ comes out exactly as the CLI
sees it); this script turns its meshes, materials, lights and camera into Blender data with
the inverse of the addon's export conversions (addon/gradphoton/export/): GGX alpha back to
Blender roughness (sqrt), intensity I back to watts 4 pi I, one-sided emission kept through the
material's gradphoton setting, a point or spot light's radius as its Radius (shadow_soft_size).
The World's medium (`world_medium`, homogeneous) becomes the World's Volume output (Volume Scatter
plus Volume Absorption, Cycles' coefficients) and `volume_bounces` Light Paths > Volume (no limit:
the bounces' 30); media inside meshes are not converted (a message says so). The camera keeps the
file's clip distances (Blender's default Clip Start of 0.1 m would hide the fog in front of it).
The saved file uses gradphoton as its render engine.
"""
import json
import math
import os
import sys

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))


def _principled(name, m):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    color = tuple(m["color"]) + (1.0,)
    bsdf.inputs["Base Color"].default_value = color
    bsdf.inputs["Roughness"].default_value = math.sqrt(max(0.0, m["roughness"]))
    if m["type"] == "conductor":
        bsdf.inputs["Metallic"].default_value = 1.0
    elif m["type"] == "dielectric":
        bsdf.inputs["Transmission"].default_value = 1.0
        bsdf.inputs["IOR"].default_value = m["ior"]
        if m["cauchy_b"] > 0:
            mat.gradphoton.dispersion, mat.gradphoton.cauchy_b = 'CAUCHY', m["cauchy_b"]
    elif m["type"] == "diffuse" and not (m["strength"] > 0 and max(m["emission"]) > 0):
        # A Lambertian surface is Blender's Diffuse BSDF (a Principled BSDF's diffuse is Burley's).
        nodes = mat.node_tree.nodes
        nodes.remove(bsdf)
        diffuse = nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = color
        mat.node_tree.links.new(diffuse.outputs[0], nodes["Material Output"].inputs["Surface"])
        return mat
    elif m["type"] == "diffuse":  # emissive: the Principled's own emission, Specular 0
        bsdf.inputs["Specular"].default_value = 0.0
    if m["type"] == "emission":
        nodes = mat.node_tree.nodes
        nodes.remove(bsdf)
        em = nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = tuple(m["emission"]) + (1.0,)
        em.inputs["Strength"].default_value = m["strength"]
        mat.node_tree.links.new(em.outputs[0], nodes["Material Output"].inputs["Surface"])
    elif m["strength"] > 0 and max(m["emission"]) > 0:
        bsdf.inputs["Emission"].default_value = tuple(m["emission"]) + (1.0,)
        bsdf.inputs["Emission Strength"].default_value = m["strength"]
    if m["strength"] > 0 and max(m["emission"]) > 0 and not m["two_sided"]:
        mat.gradphoton.emission_one_sided = True
    return mat


def _mesh(scene, d, materials):
    me = bpy.data.meshes.new(d["name"])
    pos, idx = d["positions"], d["indices"]
    me.vertices.add(len(pos))
    me.vertices.foreach_set("co", pos.reshape(-1))
    me.loops.add(idx.size)
    me.loops.foreach_set("vertex_index", idx.reshape(-1).astype("int32"))
    me.polygons.add(len(idx))
    me.polygons.foreach_set("loop_start", list(range(0, idx.size, 3)))
    me.polygons.foreach_set("loop_total", [3] * len(idx))
    used = sorted(set(int(i) for i in d["material_ids"]))
    for i in used:
        me.materials.append(materials[i])
    slot = {m: k for k, m in enumerate(used)}
    me.polygons.foreach_set("material_index", [slot[int(i)] for i in d["material_ids"]])
    me.polygons.foreach_set("use_smooth", [d["normals"] is not None] * len(idx))
    me.update(calc_edges=True)
    me.validate()
    ob = bpy.data.objects.new(d["name"], me)
    scene.collection.objects.link(ob)


def _light(scene, l):
    emit = l["emit"]
    peak = max(emit)
    color = tuple(c / peak for c in emit) if peak > 0 else (1.0, 1.0, 1.0)
    if l["type"] == "environment":
        world = scene.world or bpy.data.worlds.new("World")
        scene.world = world
        world.use_nodes = True
        bg = world.node_tree.nodes["Background"]
        bg.inputs["Color"].default_value = color + (1.0,)
        bg.inputs["Strength"].default_value = peak
        return
    kind = {"point": 'POINT', "spot": 'SPOT', "sun": 'SUN'}[l["type"]]
    la = bpy.data.lights.new(l["name"], kind)
    la.color = color
    la.shadow_soft_size = l.get("radius", 0.0)
    if kind == 'SUN':
        la.energy = peak  # irradiance, W/m^2
        la.angle = 0.0
    else:
        la.energy = 4.0 * math.pi * peak  # intensity I = P / (4 pi)
    if kind == 'SPOT':
        la.spot_size = 2.0 * math.acos(l["spot_cos_half"])
        la.spot_blend = l["spot_smooth"] / max(1e-6, 1.0 - l["spot_cos_half"])
    ob = bpy.data.objects.new(l["name"], la)
    ob.location = l["position"]
    d = l["direction"]
    # The light shines along its local -Z.
    from mathutils import Vector
    ob.rotation_euler = Vector(d).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(ob)


def _camera(scene, c):
    from mathutils import Matrix
    cam = bpy.data.cameras.new("Camera")
    cam.sensor_fit = c["sensor_fit"].upper()
    fov = math.radians(c["fov"])
    if cam.sensor_fit == 'VERTICAL':
        cam.angle_y = fov
    else:
        cam.angle_x = fov  # AUTO fits the larger side, which Blender measures with sensor_width
    if c["aperture_radius"] > 0:
        cam.dof.use_dof = True
        cam.dof.focus_distance = c["focus_distance"]
        cam.dof.aperture_fstop = cam.lens * 1e-3 / (2.0 * c["aperture_radius"])
    # Film > Pixel Filter as the file's camera (scene files default to a one-pixel box).
    f = c.get("pixel_filter", {"type": "box", "width": 1.0})
    kinds = {"box": 'BOX', "gaussian": 'GAUSSIAN', "blackman-harris": 'BLACKMAN_HARRIS'}
    if hasattr(scene, "cycles"):
        scene.cycles.pixel_filter_type = kinds.get(f["type"], 'BOX')
        scene.cycles.filter_width = f["width"]
    # Blender's Clip Start has a minimum of 1e-6 m; the file's default 0 means no clipping.
    cam.clip_start = max(1e-6, c["clip_start"])
    cam.clip_end = c["clip_end"] if math.isfinite(c["clip_end"]) else 1e5
    ob = bpy.data.objects.new("Camera", cam)
    ob.matrix_world = Matrix([list(r) for r in c["matrix"]])
    scene.collection.objects.link(ob)
    scene.camera = ob
    scene.render.resolution_x, scene.render.resolution_y = c["width"], c["height"]
    scene.render.resolution_percentage = 100


def _coefficient(v):
    return [float(v)] * 3 if isinstance(v, (int, float)) else [float(x) for x in v]


def _world_medium(scene, desc):
    """The file's World medium as the World's Volume output: Volume Scatter (colour sigma_s / d,
    density d = max sigma_s, Anisotropy g) plus Volume Absorption (sigma_a = (1 - colour) density,
    as Cycles' volume_absorption_setup), or nothing when the file has none."""
    name = desc.get("world_medium")
    if not name:
        return
    m = desc.get("media", {})[name]
    if any(k in m for k in ("grid", "density_grid", "vdb", "file")):
        print(f"json_to_blend: the World medium '{name}' is a grid medium: not converted")
        return
    sigma_s, sigma_a = _coefficient(m.get("sigma_s", 0.0)), _coefficient(m.get("sigma_a", 0.0))
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    add = nt.nodes.new("ShaderNodeAddShader")
    scatter = nt.nodes.new("ShaderNodeVolumeScatter")
    d = max(sigma_s)
    scatter.inputs["Density"].default_value = d
    scatter.inputs["Color"].default_value = tuple(x / d if d > 0 else 0.0 for x in sigma_s) + (1.0,)
    scatter.inputs["Anisotropy"].default_value = float(m.get("g", 0.0))
    absorb = nt.nodes.new("ShaderNodeVolumeAbsorption")
    da = max(sigma_a)
    absorb.inputs["Density"].default_value = da
    absorb.inputs["Color"].default_value = tuple(1.0 - x / da if da > 0 else 1.0 for x in sigma_a) + (1.0,)
    nt.links.new(scatter.outputs[0], add.inputs[0])
    nt.links.new(absorb.outputs[0], add.inputs[1])
    nt.links.new(add.outputs[0], nt.nodes["World Output"].inputs["Volume"])
    if "emission" in m:
        print(f"json_to_blend: the World medium '{name}''s emission is not converted")
    if hasattr(scene, "cycles"):
        vb = desc.get("volume_bounces", -1)
        scene.cycles.volume_bounces = vb if vb >= 0 else 30


def build(json_path, scene=None):
    """Replaces the objects of `scene` (default: the current one) with those of json_path."""
    import addon_utils
    addon_utils.enable("gradphoton", default_set=True)
    from gradphoton import native
    N = native.get()
    s = N.load_scene(os.path.abspath(json_path))
    scene = scene or bpy.context.scene
    for ob in list(scene.objects):
        bpy.data.objects.remove(ob)
    materials = [_principled(m["name"], m) for m in s.materials()]
    for d in s.meshes():
        _mesh(scene, d, materials)
    for l in s.lights():
        _light(scene, l)
    if not any(l["type"] == "environment" for l in s.lights()):
        scene.world = scene.world or bpy.data.worlds.new("World")
        scene.world.use_nodes = True
        scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    _camera(scene, s.camera())
    with open(json_path) as f:
        desc = json.load(f)
    _world_medium(scene, desc)
    if any("interior" in m for m in desc.get("materials", {}).values() if isinstance(m, dict)):
        print("json_to_blend: media inside meshes (`interior`) are not converted")
    scene.render.engine = "GRADPHOTON"
    return scene


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(args) != 2:
        sys.exit("usage: blender -b --factory-startup --python scripts/json_to_blend.py -- SCENE.json OUT.blend")
    build(args[0])
    out = os.path.abspath(args[1])
    os.makedirs(os.path.dirname(out), exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=out)
    print(f"json_to_blend: wrote {out}")
