"""Cycles 3.4's further closures and its pixel filter through the exporter: Diffuse Roughness
(Oren-Nayar), Transparent of any colour, Translucent, Refraction and Velvet BSDFs map onto the
core's types and load; Film > Pixel Filter goes to the camera. Two renders against Cycles (issue
30's cases): a Diffuse BSDF of Roughness 1 in a grey world, and a Mix of a red and a blue
Transparent BSDF in front of a white emitter."""
import os

import bpy
import numpy as np

import scenes
from gradphoton import export, native


def _material(name, kind, **inputs):
    m, nt, out = scenes._node_material(name)
    n = nt.nodes.new(kind)
    for k, v in inputs.items():
        n.inputs[k].default_value = v
    nt.links.new(n.outputs[0], out.inputs["Surface"])
    return m, nt, out, n


def _sphere(scene, mat, location=(0, 0, 1), radius=1.0):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=radius, location=location)
    ob = bpy.context.active_object
    ob.data.materials.append(mat)
    bpy.ops.object.shade_smooth()
    return ob


def test_closures_and_pixel_filter_export(empty_scene):
    scenes.add_camera(empty_scene, (0, -8, 1), (0, 0, 1))
    rough, *_ = _material("Rough", "ShaderNodeBsdfDiffuse", Roughness=0.6)
    leaf, *_ = _material("Leaf", "ShaderNodeBsdfTranslucent", Color=(0.2, 0.6, 0.1, 1))
    cloth, *_ = _material("Cloth", "ShaderNodeBsdfVelvet", Sigma=0.4)
    refr, _, _, refr_node = _material("Refr", "ShaderNodeBsdfRefraction", IOR=1.33)
    refr_node.distribution = 'GGX'  # Blender 3.4's default, Beckmann, renders as GGX with a warning
    mix, nt, out, _ = _material("Purple", "ShaderNodeMixShader")
    for i, c in ((1, (1, 0, 0, 1)), (2, (0, 0, 1, 1))):
        t = nt.nodes.new("ShaderNodeBsdfTransparent")
        t.inputs["Color"].default_value = c
        nt.links.new(t.outputs[0], nt.nodes["Mix Shader"].inputs[i])
    for k, m in enumerate((rough, leaf, cloth, refr, mix)):
        _sphere(empty_scene, m, location=(3 * k - 6, 0, 1))
    empty_scene.cycles.pixel_filter_type = 'GAUSSIAN'
    empty_scene.cycles.filter_width = 2.5
    ex = export.export_scene(bpy.context.evaluated_depsgraph_get())
    mats = ex.description["materials"]
    assert mats["Rough"]["type"] == "diffuse" and abs(mats["Rough"]["roughness"] - 0.6) < 1e-6
    assert mats["Leaf"]["type"] == "translucent"
    assert mats["Cloth"]["type"] == "velvet" and abs(mats["Cloth"]["sigma"] - 0.4) < 1e-6
    assert mats["Refr"]["type"] == "refraction" and abs(mats["Refr"]["ior"] - 1.33) < 1e-6
    parts = [mats[mats["Purple"][k]] for k in ("a", "b")]
    assert [p["type"] for p in parts] == ["transparent", "transparent"]
    assert parts[0]["color"] == [1.0, 0.0, 0.0] and parts[1]["color"] == [0.0, 0.0, 1.0]
    assert ex.description["camera"]["pixel_filter"] == {"type": "gaussian", "width": 2.5}
    assert not ex.warnings, ex.warnings.summary()
    ex.build(native.get())  # the core loads every one of them


def _render_mean(scene, path, engine, samples):
    scenes.configure_cycles(scene, samples, 8)
    if engine == 'GRADPHOTON':
        scene.render.engine = 'GRADPHOTON'
        g = scene.gradphoton
        g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', samples, 8
    img = native.get().read_exr(scenes.render_to_exr(scene, path))["combined"][..., :3].astype(np.float64)
    return img


def test_oren_nayar_and_tinted_transparency_as_bright_as_cycles(empty_scene, out_dir):
    # Issue 30: a Roughness 1 Diffuse BSDF in a grey world rendered Lambertian, 1.18 x Cycles'
    # mean; a Mix of a red and a blue Transparent BSDF rendered grey diffuse, 1.19 x.
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 32, 24
    scenes.set_world(empty_scene, (0.5, 0.5, 0.5), 1.0)
    scenes.add_camera(empty_scene, (0, -6, 1), (0, 0, 1), lens=50.0)
    rough, *_ = _material("Rough", "ShaderNodeBsdfDiffuse", Roughness=1.0)
    _sphere(empty_scene, rough)
    c = _render_mean(empty_scene, os.path.join(str(out_dir), "on_cycles.exr"), 'CYCLES', 64)
    g = _render_mean(empty_scene, os.path.join(str(out_dir), "on_gp.exr"), 'GRADPHOTON', 64)
    ratio = g.sum() / c.sum()
    print(f"BRIGHTNESS oren-nayar: gradphoton/cycles = {ratio:.4f}")
    assert abs(ratio - 1) < 0.01

    bpy.data.objects.remove(bpy.data.objects["Sphere"])
    mix, nt, out, _ = _material("Purple", "ShaderNodeMixShader")
    for i, col in ((1, (1, 0, 0, 1)), (2, (0, 0, 1, 1))):
        t = nt.nodes.new("ShaderNodeBsdfTransparent")
        t.inputs["Color"].default_value = col
        nt.links.new(t.outputs[0], nt.nodes["Mix Shader"].inputs[i])
    _sphere(empty_scene, mix)
    c = _render_mean(empty_scene, os.path.join(str(out_dir), "tr_cycles.exr"), 'CYCLES', 64)
    g = _render_mean(empty_scene, os.path.join(str(out_dir), "tr_gp.exr"), 'GRADPHOTON', 64)
    ratio = g.sum() / c.sum()
    print(f"BRIGHTNESS transparent mix: gradphoton/cycles = {ratio:.4f}, "
          f"means {g.reshape(-1, 3).mean(0).round(4)} / {c.reshape(-1, 3).mean(0).round(4)}")
    assert abs(ratio - 1) < 0.01
