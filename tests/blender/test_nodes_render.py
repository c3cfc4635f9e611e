"""Node graphs rendered by gradphoton (the core's evaluator, through export/nodes.py) against
Cycles 3.4 in this Blender.

Emission planes: a camera-facing plane fills a 64 x 64 orthographic frame, its Emission colour
(strength 1) the graph's output, read at coordinates snapped to the centre of each pixel's UV
cell (scenes.snapped_uv), so a pixel's value does not depend on where a renderer samples it.
Cycles renders one sample at each pixel's centre (box filter 0.01 px wide): the exact value.
gradphoton's path tracer renders PASSES passes, samples jittered over the pixel; a sample
within float rounding of a pixel's edge may read the neighbouring cell (a few per image), which
moves that pixel by at most |neighbour - value| / PASSES. Every pixel and channel must agree
within TOL where the core evaluates the node as Cycles does: each test prints its largest
difference (docs/blender.md, "Nodes", gives them).

The Checker ground (the issue's scene): a Checker Texture (Generated coordinates, the node's
default) into a Diffuse floor under a sun, compared as test_textures compares its floors
(mean within 0.5 %, relMSE below a bound about twice what was measured).
"""
import os

import numpy as np
import pytest

import scenes
from test_cycles_brightness import read_rgb, relmse, render_both

SIZE = 64
PASSES = 256
TOL = 1e-3

BLEND_MODES = ['MIX', 'DARKEN', 'MULTIPLY', 'BURN', 'LIGHTEN', 'SCREEN', 'DODGE', 'ADD', 'OVERLAY',
               'SOFT_LIGHT', 'LINEAR_LIGHT', 'DIFFERENCE', 'SUBTRACT', 'DIVIDE', 'HUE', 'SATURATION', 'COLOR',
               'VALUE']


def render_plane(scene, out_dir, case):
    """(gradphoton, Cycles) images of the emission plane."""
    scenes.configure_cycles_centres(scene)
    cycles = read_rgb(scenes.render_to_exr(scene, os.path.join(out_dir, f"{case}_cycles.exr")))
    scene.render.engine = 'GRADPHOTON'
    g = scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', PASSES, 0
    ours = read_rgb(scenes.render_to_exr(scene, os.path.join(out_dir, f"{case}_gradphoton.exr")))
    return ours, cycles


def check_plane(scene, out_dir, case, build, tol=TOL):
    scenes.emission_plane(scene, case, build, SIZE)
    ours, cycles = render_plane(scene, out_dir, case)
    # Cycles lets emission go negative (Musgrave fBM's Fac dips below 0); gradphoton's emission
    # is never negative (radiance, photon flux and MIS weights assume it): black there.
    cycles = np.maximum(cycles, 0.0)
    diff = np.abs(ours - cycles)
    worst = np.unravel_index(np.argmax(diff), diff.shape)
    print(f"NODES {case}: max |gradphoton - Cycles| = {diff.max():.2e} at {worst} "
          f"(Cycles {cycles[worst]:.4f}), mean {diff.mean():.2e}, Cycles range "
          f"{cycles.min():.3f}..{cycles.max():.3f}")
    # The image must vary, or the comparison says little.
    assert cycles.std() > 0.02, f"{case}: Cycles' image is nearly flat"
    assert diff.max() < tol, f"{case}: max difference {diff.max():.2e} >= {tol} at {worst}"


def gradient(nt, vec):
    """A colour varying over the plane: (u, v, 1 - u v)."""
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    nt.links.new(vec, sep.inputs[0])
    uv = nt.nodes.new("ShaderNodeMath")
    uv.operation = 'MULTIPLY'
    nt.links.new(sep.outputs[0], uv.inputs[0])
    nt.links.new(sep.outputs[1], uv.inputs[1])
    inv = nt.nodes.new("ShaderNodeMath")
    inv.operation = 'SUBTRACT'
    inv.inputs[0].default_value = 1.0
    nt.links.new(uv.outputs[0], inv.inputs[1])
    comb = nt.nodes.new("ShaderNodeCombineColor")
    nt.links.new(sep.outputs[0], comb.inputs[0])
    nt.links.new(sep.outputs[1], comb.inputs[1])
    nt.links.new(inv.outputs[0], comb.inputs[2])
    return comb.outputs[0]


@pytest.mark.parametrize("mode", BLEND_MODES)
def test_mix_rgb_blend_modes(empty_scene, out_dir, mode):
    """Mix RGB, each of its 18 blend modes, factor 0.7 (clamped result), of the gradient and a
    second colour field (1 - v, u v, 0.5 u + 0.25)."""
    def build(nt, vec):
        a = gradient(nt, vec)
        sep = nt.nodes.new("ShaderNodeSeparateXYZ")
        nt.links.new(vec, sep.inputs[0])
        hue = nt.nodes.new("ShaderNodeHueSaturation")  # rotate the gradient's hue: a second field
        hue.inputs["Hue"].default_value = 0.8
        nt.links.new(a, hue.inputs["Color"])
        mix = nt.nodes.new("ShaderNodeMixRGB")
        mix.blend_type = mode
        mix.use_clamp = True
        mix.inputs["Fac"].default_value = 0.7
        nt.links.new(a, mix.inputs["Color1"])
        nt.links.new(hue.outputs[0], mix.inputs["Color2"])
        return mix.outputs[0]
    check_plane(empty_scene, str(out_dir), f"mixrgb_{mode.lower()}", build)


def test_mix_node_lighten_of_a_colour(empty_scene, out_dir):
    """3.4's Mix node, Color / Lighten, of the gradient and a constant colour (the issue's case
    rendered white before)."""
    def build(nt, vec):
        mix = nt.nodes.new("ShaderNodeMix")
        mix.data_type = 'RGBA'
        mix.blend_type = 'LIGHTEN'
        sockets = {s.identifier: s for s in mix.inputs}
        sockets["Factor_Float"].default_value = 0.8
        sockets["B_Color"].default_value = (0.4, 0.2, 0.6, 1)
        nt.links.new(gradient(nt, vec), sockets["A_Color"])
        return next(s for s in mix.outputs if s.identifier == "Result_Color")
    check_plane(empty_scene, str(out_dir), "mix_lighten", build)


def _texture(kind, output, **settings):
    def build(nt, vec):
        mapping = nt.nodes.new("ShaderNodeMapping")  # the plane's 0..1 UVs over a few features
        mapping.inputs["Scale"].default_value = (2.0, 2.0, 2.0)
        mapping.inputs["Location"].default_value = (0.3, -0.2, 0.45)
        nt.links.new(vec, mapping.inputs["Vector"])
        t = scenes.new_node(nt, kind, **settings)
        nt.links.new(mapping.outputs[0], t.inputs["Vector"])
        return t.outputs[output]
    return build


TEXTURES = {
    "noise_3d": _texture("ShaderNodeTexNoise", "Color", Scale=2.0, Detail=3.0, Roughness=0.6, Distortion=0.0),
    "noise_fac_distorted": _texture("ShaderNodeTexNoise", "Fac", Scale=2.5, Detail=2.0, Distortion=0.7),
    "voronoi_f1": _texture("ShaderNodeTexVoronoi", "Color", Scale=3.0, feature='F1', distance='EUCLIDEAN'),
    "voronoi_distance": _texture("ShaderNodeTexVoronoi", "Distance", Scale=3.0, feature='F2', distance='MANHATTAN'),
    "musgrave_fbm": _texture("ShaderNodeTexMusgrave", "Fac", Scale=2.0, Detail=3.0, musgrave_type='FBM'),
    "musgrave_ridged": _texture("ShaderNodeTexMusgrave", "Fac", Scale=2.0, Detail=3.0, Offset=1.0, Gain=1.0,
                                musgrave_type='RIDGED_MULTIFRACTAL'),
    "wave_bands": _texture("ShaderNodeTexWave", "Color", Scale=2.0, Distortion=2.0, Detail=2.0),
}


@pytest.mark.parametrize("case", list(TEXTURES))
def test_procedural_textures(empty_scene, out_dir, case):
    check_plane(empty_scene, str(out_dir), case, TEXTURES[case])


def test_color_ramp_and_math(empty_scene, out_dir):
    """A Color Ramp (B-spline of four stops) of a Math chain (sine of 7 u, times v, clamped)."""
    def build(nt, vec):
        sep = nt.nodes.new("ShaderNodeSeparateXYZ")
        nt.links.new(vec, sep.inputs[0])
        mul = nt.nodes.new("ShaderNodeMath")
        mul.operation = 'MULTIPLY'
        mul.inputs[1].default_value = 7.0
        nt.links.new(sep.outputs[0], mul.inputs[0])
        sin = nt.nodes.new("ShaderNodeMath")
        sin.operation = 'SINE'
        nt.links.new(mul.outputs[0], sin.inputs[0])
        prod = nt.nodes.new("ShaderNodeMath")
        prod.operation = 'MULTIPLY_ADD'
        prod.use_clamp = True
        prod.inputs[2].default_value = 0.5
        nt.links.new(sin.outputs[0], prod.inputs[0])
        nt.links.new(sep.outputs[1], prod.inputs[1])
        ramp = nt.nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.interpolation = 'B_SPLINE'
        els = ramp.color_ramp.elements
        els[0].color = (0.05, 0.1, 0.6, 1)
        els[1].color = (0.9, 0.8, 0.1, 1)
        els.new(0.35).color = (0.8, 0.1, 0.2, 1)
        els.new(0.7).color = (0.1, 0.7, 0.3, 1)
        nt.links.new(prod.outputs[0], ramp.inputs["Fac"])
        return ramp.outputs["Color"]
    check_plane(empty_scene, str(out_dir), "color_ramp_math", build)


def test_checker_ground_against_cycles(empty_scene, out_dir):
    """A Checker Texture (its default Generated coordinates, scale 5) as a Diffuse floor's colour
    under a low sun and a dim sky: rendered flat grey before issue 30."""
    m, nt, out = scenes._node_material("Ground")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    ch.inputs["Scale"].default_value = 5.0
    ch.inputs["Color1"].default_value = (0.8, 0.7, 0.2, 1)
    ch.inputs["Color2"].default_value = (0.1, 0.2, 0.5, 1)
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(ch.outputs["Color"], d.inputs["Color"])
    nt.links.new(d.outputs[0], out.inputs["Surface"])
    scenes.set_world(empty_scene, (0.5, 0.6, 0.7), 0.3)
    scenes.add_plane(empty_scene, "Ground", 6.0, m)
    scenes.add_camera(empty_scene, (0, 0, 6), (0, 0, 0), lens=50.0)
    sun = scenes.add_light(empty_scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (3, 0, 3))
    sun.rotation_euler = (0.87, 0.0, 0.52)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 48, 36
    ours, cycles = render_both(empty_scene, str(out_dir), "checker_ground", samples=64, bounces=4)
    ratio = ours.sum() / cycles.sum()
    err = relmse(ours, cycles)
    print(f"NODES checker_ground: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f}")
    assert cycles.reshape(-1, 3).std(0).max() > 0.05  # the checker shows
    assert 0.995 < ratio < 1.005, ratio
    assert err < 0.01, err
