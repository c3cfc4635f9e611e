"""Small scenes built in Blender for the tests and benchmarks."""
import math
import os

import bpy
import numpy as np
from mathutils import Vector


def look_at(ob, target):
    d = Vector(target) - ob.location
    ob.rotation_euler = d.to_track_quat('-Z', 'Y').to_euler()


def add_camera(scene, location=(0, 0, 10), target=(0, 0, 0), lens=50.0):
    cam = bpy.data.cameras.new("Camera")
    cam.lens = lens
    ob = bpy.data.objects.new("Camera", cam)
    scene.collection.objects.link(ob)
    ob.location = location
    look_at(ob, target)
    scene.camera = ob
    return ob


def _node_material(name):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    return m, nt, nt.nodes.new("ShaderNodeOutputMaterial")


def new_node(nt, kind, **settings):
    """A node of `kind` in node tree `nt`; each setting is an input's default value where the node
    has an input of that name, else a property of the node (distribution, blend_type, ...)."""
    n = nt.nodes.new(kind)
    for k, v in settings.items():
        if k in n.inputs:
            n.inputs[k].default_value = v
        else:
            setattr(n, k, v)
    return n


def closure_material(name, kind, distribution, inputs):
    """A material whose Surface is one closure node of `kind` with `distribution` and `inputs`
    (socket name -> value)."""
    m, nt, out = _node_material(name)
    n = new_node(nt, kind, distribution=distribution, **inputs)
    nt.links.new(n.outputs[0], out.inputs["Surface"])
    return m


def diffuse_material(name, color=(0.8, 0.8, 0.8)):
    m, nt, out = _node_material(name)
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*color, 1)
    nt.links.new(d.outputs[0], out.inputs["Surface"])
    return m


def emission_material(name, strength, color=(1, 1, 1)):
    m, nt, out = _node_material(name)
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = (*color, 1)
    e.inputs["Strength"].default_value = strength
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    return m


def add_mesh_object(scene, name, verts, faces, material=None):
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    ob = bpy.data.objects.new(name, me)
    scene.collection.objects.link(ob)
    if material is not None:
        me.materials.append(material)
    return ob


def sphere_on_grey_floor(scene, material, camera, target):
    """A smooth unit sphere of `material` resting on a grey diffuse floor under a small point light
    (radius 0.25) in a grey World: the rough glass and metal comparisons with Cycles."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0, location=(0, 0, 1))
    bpy.ops.object.shade_smooth()
    bpy.context.active_object.data.materials.append(material)
    add_plane(scene, "Floor", 8.0, diffuse_material("Floor", (0.5, 0.5, 0.5)))
    add_light(scene, "Point", 'POINT', None, 400.0, {"shadow_soft_size": 0.25}, (1.5, -1.5, 3.5))
    set_world(scene, (0.5, 0.5, 0.5), 1.0)
    add_camera(scene, camera, target, lens=35.0)


def add_plane(scene, name, size, material=None, location=(0, 0, 0)):
    s = size / 2
    ob = add_mesh_object(scene, name, [(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], [(0, 1, 2, 3)], material)
    ob.location = location
    return ob


def set_world(scene, color=(0, 0, 0), strength=0.0):
    w = scene.world
    w.use_nodes = True
    bg = w.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (*color, 1)
    bg.inputs["Strength"].default_value = strength


def add_light(scene, name, kind, shape, power, extra, location):
    """A light object of Blender type `kind` (shape for area lights, settings in `extra`)."""
    la = bpy.data.lights.new(name, kind)
    la.energy = power
    if shape:
        la.shape = shape
    for k, v in extra.items():
        setattr(la, k, v)
    ob = bpy.data.objects.new(name, la)
    scene.collection.objects.link(ob)
    ob.location = location
    return ob


LIGHT_AT = (3.0, 0.0, 2.0)  # outside the camera's view; every light aims at the origin

# name -> (Blender light type, shape or None, power/strength, extra settings)
LIGHT_CASES = {
    "point": ('POINT', None, 400.0, {}),
    "spot": ('SPOT', None, 600.0, {"spot_size": math.radians(70), "spot_blend": 0.3}),
    "sun": ('SUN', None, 2.0, {"angle": 0.0}),
    "area_square": ('AREA', 'SQUARE', 300.0, {"size": 1.0}),
    "area_rectangle": ('AREA', 'RECTANGLE', 300.0, {"size": 1.5, "size_y": 0.5}),
    "area_disk": ('AREA', 'DISK', 300.0, {"size": 1.0}),
    "area_ellipse": ('AREA', 'ELLIPSE', 300.0, {"size": 1.2, "size_y": 0.6}),
}


def brightness_scene(scene, case):
    """A diffuse floor seen from above, lit by one light of `case` (a LIGHT_CASES key,
    'emissive_mesh' or 'world'); nothing but the floor is in view."""
    set_world(scene)
    add_plane(scene, "Floor", 40.0, diffuse_material("Floor", (0.7, 0.7, 0.7)))
    add_camera(scene, (0, 0, 10), (0, 0, 0), lens=60.0)
    if case == "world":
        set_world(scene, (0.6, 0.7, 0.8), 1.5)
    elif case == "emissive_mesh":
        ob = add_plane(scene, "Panel", 1.0, emission_material("Panel", 20.0, (1.0, 0.9, 0.8)), LIGHT_AT)
        look_at(ob, (0, 0, 0))
    else:
        kind, shape, power, extra = LIGHT_CASES[case]
        if kind in {'POINT', 'SPOT'}:
            extra = dict(extra, shadow_soft_size=0.0)
        ob = add_light(scene, case, kind, shape, power, dict(extra, color=(1.0, 0.9, 0.8)), LIGHT_AT)
        look_at(ob, (0, 0, 0))
    return scene


def configure_cycles(scene, samples, bounces=4):
    scene.render.engine = 'CYCLES'
    c = scene.cycles
    c.device = 'CPU'
    c.samples = samples
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
    c.transparent_max_bounces = bounces
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.caustics_reflective = c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.seed = 1
    # A box pixel filter of one pixel, as gradphoton's film (Cycles' default is a 1.5 px
    # Blackman-Harris, which softens edges and so the per-pixel comparison of emitters).
    c.pixel_filter_type = 'BOX'
    c.filter_width = 1.0
    scene.render.threads_mode = 'FIXED'
    scene.render.threads = 2


def render_to_exr(scene, path):
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return path


def cycles_then_pt(scene, out_dir, samples, bounces):
    """The scene rendered by Cycles as configured, then by gradphoton pt at `samples` passes and
    `bounces`: (gradphoton, cycles) RGB as float64 arrays."""
    from gradphoton import native
    cycles = native.get().read_exr(render_to_exr(scene, os.path.join(str(out_dir), "c.exr")))["combined"]
    scene.render.engine = 'GRADPHOTON'
    g = scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', samples, bounces
    ours = native.get().read_exr(render_to_exr(scene, os.path.join(str(out_dir), "g.exr")))["combined"]
    return ours[..., :3].astype(np.float64), cycles[..., :3].astype(np.float64)


def window_ratios(a, b):
    """a / b over the image and over its middle window (where the tests' volumes are seen)."""
    h, w = a.shape[:2]
    mid = (slice(h // 4, 3 * h // 4), slice(w // 3, 2 * w // 3))
    return a.sum() / b.sum(), a[mid].sum() / b[mid].sum()


def volume_at_cycles_brightness(scene, out_dir, label, window, size, samples=256, bounces=8, tol=0.01,
                                volume_step_rate=None):
    """The volume tests' comparison: the scene at `size` pixels rendered by Cycles (`samples`,
    `bounces` of every kind, volume bounces included; `volume_step_rate` if given) and by
    gradphoton pt at as many passes; the image's mean and its middle window's (`window` names
    what is seen there) within `tol` of Cycles'. Returns (gradphoton, cycles)."""
    scene.render.resolution_x, scene.render.resolution_y = size
    configure_cycles(scene, samples, bounces)
    scene.cycles.volume_bounces = bounces
    if volume_step_rate is not None:
        scene.cycles.volume_step_rate = volume_step_rate  # fine ray marching: Cycles' own bias well under 1 %
    a, b = cycles_then_pt(scene, out_dir, samples, bounces)
    ratio, ratio_mid = window_ratios(a, b)
    print(f"VOLUME {label}: gradphoton/cycles = {ratio:.4f} ({window} window {ratio_mid:.4f}); "
          f"gradphoton {a.reshape(-1, 3).mean(0).round(4)}, cycles {b.reshape(-1, 3).mean(0).round(4)}")
    assert abs(ratio - 1) < tol, ratio
    assert abs(ratio_mid - 1) < tol, ratio_mid
    return a, b


def glass_material(name, ior=1.5):
    m, nt, out = _node_material(name)
    g = nt.nodes.new("ShaderNodeBsdfGlass")
    g.inputs["Roughness"].default_value = 0.0
    g.inputs["IOR"].default_value = ior
    g.distribution = 'SHARP'
    nt.links.new(g.outputs[0], out.inputs["Surface"])
    return m


CORNELL_QUADS = {  # inward-facing walls of the room x, y in [-1, 1], z in [0, 2]
    "Floor": ([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], "White"),
    "Ceiling": ([(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], "White"),
    "Back": ([(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], "White"),
    "Left": ([(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], "Red"),
    "Right": ([(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], "Green"),
}


def cornell_room(scene):
    """The Cornell room's five Diffuse BSDF walls and its camera (no light)."""
    set_world(scene)
    mats = {"White": diffuse_material("White", (0.73, 0.73, 0.73)), "Red": diffuse_material("Red", (0.63, 0.065, 0.05)),
            "Green": diffuse_material("Green", (0.14, 0.45, 0.09))}
    for name, (v, m) in CORNELL_QUADS.items():
        add_mesh_object(scene, name, v, [(0, 1, 2, 3)], mats[m])
    add_camera(scene, (0, -3.9, 1), (0, 0, 1), lens=50.0)
    return mats


# Cornell room lit as a new user lights it: name -> (Blender light type, shape, power, settings);
# every light sits just under the ceiling, in view, pointing down.
CORNELL_LIGHTS = {
    "area": ('AREA', 'SQUARE', 60.0, {"size": 0.5}),
    "area_disk": ('AREA', 'DISK', 60.0, {"size": 0.5}),
    "point": ('POINT', None, 60.0, {"shadow_soft_size": 0.1}),  # 0.1 m radius, 0.2 m below the ceiling
    "spot": ('SPOT', None, 100.0, {"shadow_soft_size": 0.1, "spot_size": math.radians(100), "spot_blend": 0.2}),
    "sun": ('SUN', None, 3.0, {"angle": math.radians(10)}),
}


def cornell_lit(scene, case):
    """The Cornell room with one light of CORNELL_LIGHTS[case] (Blender's defaults otherwise:
    the light object is not visible to the camera), or 'emissive_mesh': a 0.5 m emissive
    square under the ceiling. A sun shines in through a hole: the ceiling is left out."""
    mats = cornell_room(scene)
    if case == "emissive_mesh":
        add_mesh_object(scene, "Lamp", [(-0.25, -0.25, 1.98), (-0.25, 0.25, 1.98), (0.25, 0.25, 1.98),
                                        (0.25, -0.25, 1.98)], [(0, 1, 2, 3)], emission_material("Lamp", 60.0))
        return mats
    kind, shape, power, extra = CORNELL_LIGHTS[case]
    if kind == 'SUN':
        bpy.data.objects.remove(bpy.data.objects["Ceiling"])
    ob = add_light(scene, case, kind, shape, power, extra, (0.0, 0.0, 1.98 if kind == 'AREA' else 1.8))
    if kind == 'SUN':
        ob.rotation_euler = (math.radians(20), 0.0, 0.0)
    return mats


def principled_material(name, color=(0.7, 0.5, 0.3), roughness=0.5, metallic=0.0, transmission=0.0, ior=1.45,
                        specular=0.5):
    m, nt, out = _node_material(name)
    p = nt.nodes.new("ShaderNodeBsdfPrincipled")
    p.inputs["Specular"].default_value = specular
    p.inputs["Base Color"].default_value = (*color, 1)
    p.inputs["Roughness"].default_value = roughness
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Transmission"].default_value = transmission
    p.inputs["IOR"].default_value = ior
    nt.links.new(p.outputs[0], out.inputs["Surface"])
    return m


def mix_material(name, add=False, factor=0.3):
    """Mix (or Add) Shader of a Diffuse BSDF and a Glossy BSDF (roughness 0.3)."""
    m, nt, out = _node_material(name)
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (0.7, 0.5, 0.3, 1)
    g = nt.nodes.new("ShaderNodeBsdfGlossy")
    g.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1)
    g.inputs["Roughness"].default_value = 0.3
    g.distribution = 'GGX'
    mix = nt.nodes.new("ShaderNodeAddShader" if add else "ShaderNodeMixShader")
    if not add:
        mix.inputs["Fac"].default_value = factor
    first = 0 if add else 1
    if add:
        d.inputs["Color"].default_value = (0.35, 0.25, 0.15, 1)
        g.inputs["Color"].default_value = (0.4, 0.4, 0.4, 1)
    nt.links.new(d.outputs[0], mix.inputs[first])
    nt.links.new(g.outputs[0], mix.inputs[first + 1])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    return m


# Material cases on the Cornell room (area light): the floor and the back wall get the material.
CORNELL_MATERIALS = {
    "principled_plastic": lambda: principled_material("Plastic"),
    "principled_glossy_plastic": lambda: principled_material("GlossyPlastic", roughness=0.15),
    "principled_metal": lambda: principled_material("Metal", color=(0.9, 0.6, 0.3), roughness=0.3, metallic=1.0),
    "principled_half_metal": lambda: principled_material("HalfMetal", roughness=0.4, metallic=0.5),
    # A dark metal of Specular 1: almost all its light is the Fresnel term, where Cycles'
    # interpolated Fresnel and Schlick's differ most.
    "principled_dark_metal": lambda: principled_material("DarkMetal", color=(0.03, 0.03, 0.03), roughness=0.3,
                                                         metallic=1.0, specular=1.0),
    "mix_shader": lambda: mix_material("Mix"),
    "add_shader": lambda: mix_material("Add", add=True),
}


def cornell_material(scene, case):
    cornell_lit(scene, "area")
    m = CORNELL_MATERIALS[case]()
    for name in ("Floor", "Back"):
        me = bpy.data.objects[name].data
        me.materials.clear()
        me.materials.append(m)


def cornell_glass(scene):
    """Cornell box (x, y in [-1, 1], z in [0, 2]) with a glass sphere and a 0.5 m ceiling light."""
    set_world(scene)
    white, red, green = (diffuse_material("White", (0.73, 0.73, 0.73)), diffuse_material("Red", (0.63, 0.065, 0.05)),
                         diffuse_material("Green", (0.14, 0.45, 0.09)))
    quads = {  # inward-facing walls
        "Floor": ([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white),
        "Ceiling": ([(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white),
        "Back": ([(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white),
        "Left": ([(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red),
        "Right": ([(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], green),
    }
    for name, (v, m) in quads.items():
        add_mesh_object(scene, name, v, [(0, 1, 2, 3)], m)
    add_mesh_object(scene, "Light", [(-0.25, -0.25, 1.99), (-0.25, 0.25, 1.99), (0.25, 0.25, 1.99),
                                     (0.25, -0.25, 1.99)], [(0, 1, 2, 3)], emission_material("Lamp", 17.0))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.4, location=(0.3, 0.2, 0.4))
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(glass_material("Glass"))
    add_camera(scene, (0, -3.9, 1), (0, 0, 1), lens=50.0)


# ---- Textured scenes (export/texture.py) ----

def uv_plane(scene, name, size, material=None, location=(0, 0, 0), tiles=1.0):
    """A square plane with a UV map (uv 0..tiles across it)."""
    ob = add_plane(scene, name, size, material, location)
    uv = ob.data.uv_layers.new(name="UVMap")
    for loop, co in zip(uv.data, [(0, 0), (1, 0), (1, 1), (0, 1)]):
        loop.uv = (co[0] * tiles, co[1] * tiles)
    return ob


def save_image(name, pixels, path, colorspace='sRGB'):
    """An 8-bit PNG of RGBA pixels (h, w, 4; row 0 at the bottom, values as stored), loaded back
    as a file image in `colorspace`, as an image of a downloaded scene."""
    import numpy as np
    if name in bpy.data.images:  # from an earlier test (the test fixture keeps images)
        bpy.data.images.remove(bpy.data.images[name])
    h, w = pixels.shape[:2]
    tmp = bpy.data.images.new(name + "_tmp", w, h, alpha=True)
    tmp.pixels.foreach_set(np.asarray(pixels, np.float32).ravel())
    tmp.filepath_raw = path
    tmp.file_format = 'PNG'
    tmp.save()
    bpy.data.images.remove(tmp)
    img = bpy.data.images.load(path)
    img.name = name
    img.colorspace_settings.name = colorspace
    return img


def pattern_pixels(n=32):
    """A colour checker over a smooth gradient (n x n RGBA)."""
    import numpy as np
    y, x = np.mgrid[0:n, 0:n] / (n - 1)
    check = ((np.mgrid[0:n, 0:n][0] // 4 + np.mgrid[0:n, 0:n][1] // 4) % 2).astype(float)
    r = 0.2 + 0.6 * x * check + 0.1 * (1 - check)
    g = 0.3 + 0.4 * y
    b = 0.8 - 0.5 * check
    return np.dstack([r, g, b, np.ones_like(r)])


def normal_map_pixels(n=32, k=3, a=0.6):
    """A tangent-space normal map of sine bumps (n x n RGBA, Non-Color values)."""
    import numpy as np
    y, x = np.mgrid[0:n, 0:n] / n
    nx, ny = -a * np.cos(2 * np.pi * k * x), -a * np.cos(2 * np.pi * k * y)
    norm = np.sqrt(nx * nx + ny * ny + 1)
    return np.dstack([(nx / norm + 1) / 2, (ny / norm + 1) / 2, (1 / norm + 1) / 2, np.ones_like(nx)])


def image_node(nt, image, interpolation='Linear'):
    t = nt.nodes.new("ShaderNodeTexImage")
    t.image = image
    t.interpolation = interpolation
    return t


def textured_material(name, case, color_image, normal_image=None):
    """Material cases for the textured floor: 'diffuse' (an image as Diffuse colour),
    'normal_map' (white Diffuse with a normal map), 'mix' (Mix Shader of Diffuse and Glossy,
    Fac from the image), 'principled' (Principled with a base colour, a roughness map and a
    normal map)."""
    m, nt, out = _node_material(name)
    tex = image_node(nt, color_image)
    if case in ("diffuse", "normal_map"):
        d = nt.nodes.new("ShaderNodeBsdfDiffuse")
        if case == "diffuse":
            nt.links.new(tex.outputs["Color"], d.inputs["Color"])
        else:
            d.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1)
            nm = nt.nodes.new("ShaderNodeNormalMap")
            nt.links.new(image_node(nt, normal_image).outputs["Color"], nm.inputs["Color"])
            nt.links.new(nm.outputs["Normal"], d.inputs["Normal"])
        nt.links.new(d.outputs[0], out.inputs["Surface"])
    elif case == "mix":
        d = nt.nodes.new("ShaderNodeBsdfDiffuse")
        d.inputs["Color"].default_value = (0.7, 0.5, 0.3, 1)
        g = nt.nodes.new("ShaderNodeBsdfGlossy")
        g.inputs["Roughness"].default_value = 0.3
        g.distribution = 'GGX'
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(tex.outputs["Color"], mix.inputs["Fac"])
        nt.links.new(d.outputs[0], mix.inputs[1])
        nt.links.new(g.outputs[0], mix.inputs[2])
        nt.links.new(mix.outputs[0], out.inputs["Surface"])
    else:
        p = nt.nodes.new("ShaderNodeBsdfPrincipled")
        nt.links.new(tex.outputs["Color"], p.inputs["Base Color"])
        sep = nt.nodes.new("ShaderNodeSeparateColor")
        nt.links.new(tex.outputs["Color"], sep.inputs[0])
        nt.links.new(sep.outputs["Green"], p.inputs["Roughness"])
        nm = nt.nodes.new("ShaderNodeNormalMap")
        nt.links.new(image_node(nt, normal_image).outputs["Color"], nm.inputs["Color"])
        nt.links.new(nm.outputs["Normal"], p.inputs["Normal"])
        nt.links.new(p.outputs[0], out.inputs["Surface"])
    return m


def textured_floor(scene, case, folder):
    """A textured floor (case as textured_material) seen from above under a low sun and a dim
    sky, its images saved as PNG files in `folder`."""
    import os
    set_world(scene, (0.5, 0.6, 0.7), 0.3)
    color = save_image("Pattern", pattern_pixels(), os.path.join(folder, "pattern.png"))
    normal = save_image("Bumps", normal_map_pixels(), os.path.join(folder, "bumps.png"), 'Non-Color')
    uv_plane(scene, "Floor", 6.0, textured_material("Textured", case, color, normal), tiles=2.0)
    add_camera(scene, (0, 0, 6), (0, 0, 0), lens=50.0)
    sun = add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (3, 0, 3))
    sun.rotation_euler = (math.radians(50), 0.0, math.radians(30))
    return scene


# ---- Node-graph scenes (export/nodes.py) ----

def snapped_uv(nt, cells):
    """A Vector output constant over each of cells x cells squares of the UV square: the UV of
    the square's centre (Vector Math Snap, then half a cell added). On a plane that fills the
    frame with one square per pixel, every sample of a pixel reads its centre's value, so a
    texture's value per pixel does not depend on where in the pixel a renderer samples."""
    tc = nt.nodes.new("ShaderNodeTexCoord")
    snap = nt.nodes.new("ShaderNodeVectorMath")
    snap.operation = 'SNAP'
    snap.inputs[1].default_value = (1.0 / cells, 1.0 / cells, 1.0)
    nt.links.new(tc.outputs["UV"], snap.inputs[0])
    half = nt.nodes.new("ShaderNodeVectorMath")
    half.operation = 'ADD'
    half.inputs[1].default_value = (0.5 / cells, 0.5 / cells, 0.0)
    nt.links.new(snap.outputs[0], half.inputs[0])
    return half.outputs[0]


def emission_plane(scene, name, build, size=64):
    """A camera-facing emission plane filling a size x size orthographic frame (one UV cell per
    pixel), its Emission colour (strength 1) from build(node_tree, vector_socket) -> a socket;
    the World black, no lights."""
    set_world(scene)
    m, nt, out = _node_material(name)
    e = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(build(nt, snapped_uv(nt, size)), e.inputs["Color"])
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    uv_plane(scene, "Plane", 2.0, m)
    cam = add_camera(scene, (0, 0, 5), (0, 0, 0))
    cam.data.type = 'ORTHO'
    cam.data.ortho_scale = 2.0
    cam.rotation_euler = (0.0, 0.0, 0.0)
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    return m


def configure_cycles_centres(scene):
    """Cycles with one sample at each pixel's centre (a box filter 0.01 pixels wide): the exact
    value of an emission plane's colour there, no noise."""
    configure_cycles(scene, 1, 0)
    scene.cycles.filter_width = 0.01
