"""Reference values of procedural textures from Blender 3.4's Cycles, for
tests/native/shading_procedural_test.cpp. Each case of shading_cases.json is rendered as N x N
emission quads under an orthographic camera, one quad per pixel, quad (i, j) (j from the bottom)
with its own material whose texture node reads the constant Vector (a Combine XYZ)
(X0 + (i + 0.5) / N, Y0 + (j + 0.5) / N, 0): exact binary fractions, so Cycles evaluates the
node at exactly the point the test does (a texture coordinate would carry the ray's rounding and
the pixel filter's jitter, which hash-based textures amplify). Writes shading_refs.json.

  blender -b --factory-startup --python tests/blender_refs/render_shading_refs.py
"""
import json
import os
import tempfile

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
N = 4
X0, Y0 = 0.359375, 0.203125  # 23/64, 13/64


def setup():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = 'CYCLES'
    sc.cycles.device = 'CPU'
    sc.cycles.samples = 1
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.use_denoising = False
    sc.cycles.pixel_filter_type = 'BOX'
    sc.cycles.filter_width = 0.01
    sc.cycles.max_bounces = 0
    sc.render.resolution_x = sc.render.resolution_y = N
    sc.render.resolution_percentage = 100
    sc.view_settings.view_transform = 'Standard'
    sc.view_settings.look = 'None'
    sc.render.image_settings.file_format = 'OPEN_EXR'
    sc.render.image_settings.color_depth = '32'
    world = bpy.data.worlds.new("W")
    world.color = (0, 0, 0)
    sc.world = world
    mats = []
    for j in range(N):
        for i in range(N):
            x, y = X0 + i / N, Y0 + j / N
            mesh = bpy.data.meshes.new(f"P{i}{j}")
            mesh.from_pydata([(x, y, 0), (x + 1 / N, y, 0), (x + 1 / N, y + 1 / N, 0), (x, y + 1 / N, 0)], [],
                             [(0, 1, 2, 3)])
            obj = bpy.data.objects.new(f"P{i}{j}", mesh)
            sc.collection.objects.link(obj)
            mat = bpy.data.materials.new(f"M{i}{j}")
            mat.use_nodes = True
            obj.data.materials.append(mat)
            mats.append((mat, (X0 + (i + 0.5) / N, Y0 + (j + 0.5) / N, 0.0)))
    cam_data = bpy.data.cameras.new("C")
    cam_data.type = 'ORTHO'
    cam_data.ortho_scale = 1.0
    cam = bpy.data.objects.new("C", cam_data)
    cam.location = (X0 + 0.5, Y0 + 0.5, 5.0)
    sc.collection.objects.link(cam)
    sc.camera = cam
    return sc, mats


def render_case(sc, mats, case):
    for mat, point in mats:
        nt = mat.node_tree
        nt.nodes.clear()
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Strength"].default_value = 1.0
        tex = nt.nodes.new(case["type"])
        for k, v in case["props"].items():
            if k == "color_ramp":
                ramp = tex.color_ramp
                ramp.interpolation = v["interpolation"]
                ramp.color_mode = v["color_mode"]
                ramp.hue_interpolation = v["hue_interpolation"]
                els = v["elements"]
                while len(ramp.elements) < len(els):
                    ramp.elements.new(0.5)
                for e, d in zip(ramp.elements, els):
                    e.position = d["position"]
                for e, d in zip(sorted(ramp.elements, key=lambda e: e.position), els):
                    e.color = d["color"]
                continue
            setattr(tex, k, v)
        for k, v in case["inputs"].items():
            sock = next(s for s in tex.inputs if s.identifier == k)
            if sock.type == 'RGBA' and len(v) == 3:
                v = list(v) + [1.0]
            sock.default_value = v
        # A texture's unlinked Vector reads the texture coordinates, never its hidden value:
        # the point comes through a Combine XYZ (which Cycles folds into the constant), into
        # the input named by "vary" (default Vector; converted to a float input as Cycles does).
        vary = case.get("vary", "Vector")
        if vary is not None:
            xyz = nt.nodes.new("ShaderNodeCombineXYZ")
            for k in range(3):
                xyz.inputs[k].default_value = point[k]
            nt.links.new(xyz.outputs[0], next(s for s in tex.inputs if s.identifier == vary))
        src = next(s for s in tex.outputs if s.identifier == case["output"])
        nt.links.new(src, em.inputs["Color"])
        nt.links.new(em.outputs[0], out.inputs["Surface"])
    path = os.path.join(tempfile.gettempdir(), "gp_shading_ref.exr")
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = list(img.pixels)
    bpy.data.images.remove(img)
    values = []
    for j in range(N):
        for i in range(N):
            k = 4 * (j * N + i)
            values.append([px[k], px[k + 1], px[k + 2]])
    return values


def main():
    with open(os.path.join(HERE, "shading_cases.json")) as f:
        cases = json.load(f)
    sc, mats = setup()
    result = {"n": N, "x0": X0, "y0": Y0, "blender": bpy.app.version_string, "cases": {}}
    for case in cases:
        result["cases"][case["name"]] = render_case(sc, mats, case)
    with open(os.path.join(HERE, "shading_refs.json"), "w") as f:
        json.dump(result, f, indent=0)


main()
