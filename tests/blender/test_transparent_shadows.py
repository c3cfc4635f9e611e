"""Transparent shadows (the core's paths/medium_walk.h ShadowTest): shadow rays pass a Transparent
BSDF multiplied by its closure weight at the hit, as Cycles 3.4's do (shade_shadow.h), up to
Light Paths > Max Bounces > Transparent, which the exporter writes as `transparent_bounces`."""
import bpy
import numpy as np

import scenes
from gradphoton.export import export_scene

TINT = (0.35, 0.9, 0.5)  # the leaf's transmitted colour: the shadow's colour where the leaf is open


def leaf_material(name):
    """A leaf as downloaded assets make one: a Mix Shader of a (tinted) Transparent BSDF and a
    Diffuse BSDF whose factor an alpha mask drives (here a Checker Texture's Fac on the UVs:
    0 -> transparent, 1 -> diffuse)."""
    m, nt, out = scenes._node_material(name)
    mix = nt.nodes.new("ShaderNodeMixShader")
    tr = nt.nodes.new("ShaderNodeBsdfTransparent")
    tr.inputs["Color"].default_value = (*TINT, 1)
    df = nt.nodes.new("ShaderNodeBsdfDiffuse")
    df.inputs["Color"].default_value = (0.2, 0.5, 0.1, 1)
    tc = nt.nodes.new("ShaderNodeTexCoord")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    ch.inputs["Scale"].default_value = 4.0
    nt.links.new(tc.outputs["UV"], ch.inputs["Vector"])
    nt.links.new(ch.outputs["Fac"], mix.inputs["Fac"])
    nt.links.new(tr.outputs[0], mix.inputs[1])
    nt.links.new(df.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    return m


def leaf_scene(scene):
    """A diffuse floor seen from above, a sun straight above, and between them a checkered leaf
    that the camera does not see (its shadow fills half the image)."""
    scenes.set_world(scene)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.8, 0.8, 0.8)))
    leaf = scenes.uv_plane(scene, "Leaf", 5.0, leaf_material("Leaf"), (0, 0, 1.0))
    leaf.visible_camera = False
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (0, 0, 5))
    scenes.look_at(sun, (0, 0, 0))
    scenes.add_camera(scene, (0, 0, 10), (0, 0, 0), lens=50.0)
    scene.render.resolution_x = scene.render.resolution_y = 48


def test_transparent_bounces_exported_as_cycles_reads_them(empty_scene):
    leaf_scene(empty_scene)
    for n in (8, 0, 3):
        empty_scene.cycles.transparent_max_bounces = n
        assert export_scene(bpy.context.evaluated_depsgraph_get()).description["transparent_bounces"] == n


def test_checkered_leaf_shadow_at_cycles_brightness(empty_scene, out_dir):
    leaf_scene(empty_scene)
    samples, bounces = 64, 8
    scenes.configure_cycles(empty_scene, samples, bounces)
    a, b = scenes.cycles_then_pt(empty_scene, out_dir, samples, bounces)
    ratio = a.sum() / b.sum()
    per_channel = a.reshape(-1, 3).mean(0) / b.reshape(-1, 3).mean(0)
    print(f"LEAF checkered transparent shadow: gradphoton/cycles = {ratio:.4f}, per channel {per_channel.round(4)}; "
          f"gradphoton {a.reshape(-1, 3).mean(0).round(4)}, cycles {b.reshape(-1, 3).mean(0).round(4)}")
    # The bound, 1 %, on the image and on each channel (the tint is per channel). With the
    # shadow opaque (the old behaviour) or untinted, the image is off by 10-30 %.
    assert abs(ratio - 1) < 0.01, ratio
    assert np.all(np.abs(per_channel - 1) < 0.01), per_channel
