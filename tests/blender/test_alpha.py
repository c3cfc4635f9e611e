"""Principled BSDF's Alpha and Film > Transparent through tinted surfaces, as Cycles 3.4 renders
them (issue 30).

- Alpha a: Cycles makes the Principled BSDF (its emission included) the second closure of a Mix
  Shader of factor a whose first is a white Transparent BSDF (shader_nodes.cpp
  PrincipledBsdfNode::expand). The exporter writes that mix; the core's mix with a Transparent
  BSDF is the same closure in every method (paths pick it by weight, shadow rays pass filtered).
- Film > Transparent: a camera ray that leaves the scene after transparent bounces only adds the
  average of its throughput to the transparent pass and no background (integrate_background):
  a red Transparent BSDF pane before the World gives alpha 1 - 1/3 and no colour."""
import os

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import export, native


def export_material(mat):
    """(the material's scene-format dict, the whole table, warning lines), as test_nodes.py's."""
    w = export.Warnings()
    table = {}
    export.material.MaterialExporter(table, w).name_for(mat)
    return table[mat.name], table, w.lines()


def _rgba(scene, path):
    exr = native.get().read_exr(scenes.render_to_exr(scene, path))
    if "R" in exr:  # a single-layer file
        return np.dstack([exr[c][..., 0] for c in ("R", "G", "B")]).astype(np.float64), exr["A"][..., 0].astype(np.float64)
    return exr["combined"][..., :3].astype(np.float64), exr["A"][..., 0].astype(np.float64)


def alpha_leaf_material(name, folder):
    """A leaf as downloaded assets make one: a Principled BSDF whose Alpha an image's alpha drives
    (a 4 x 4 checker of alpha 0 and 1, with a few cells at 0.5), its Base Color the image's."""
    m, nt, out = scenes._node_material(name)
    p = nt.nodes.new("ShaderNodeBsdfPrincipled")
    p.inputs["Roughness"].default_value = 0.6
    n = 4
    px = np.zeros((n, n, 4), np.float32)
    for j in range(n):
        for i in range(n):
            px[j, i] = (0.2, 0.6, 0.1, 1.0 if (i + j) % 2 else 0.0)
    px[0, 0, 3] = px[2, 1, 3] = 0.5
    img = scenes.save_image(name + "_alpha", px, os.path.join(folder, name + "_alpha.png"))
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.interpolation = 'Closest'
    nt.links.new(tex.outputs["Color"], p.inputs["Base Color"])
    nt.links.new(tex.outputs["Alpha"], p.inputs["Alpha"])
    nt.links.new(p.outputs[0], out.inputs["Surface"])
    return m


def leaf_scene(scene, folder):
    """A grey floor seen from above under a sun, a leaf with an alpha texture above it that the
    camera sees (its open cells show the floor and the leaf's shadow)."""
    scenes.set_world(scene, (0.3, 0.4, 0.5), 0.5)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.8, 0.8, 0.8)))
    scenes.uv_plane(scene, "Leaf", 4.0, alpha_leaf_material("AlphaLeaf", folder), (0.5, 0.3, 1.0))
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (1, 1, 5))
    scenes.look_at(sun, (0, 0, 0))
    scenes.add_camera(scene, (0, 0, 10), (0, 0, 0), lens=50.0)
    scene.render.resolution_x = scene.render.resolution_y = 48


def test_principled_alpha_exports_as_cycles_mix_with_a_transparent_bsdf(empty_scene, out_dir):
    """Constant and linked Alpha: a mix (factor Alpha) of a white Transparent BSDF and the rest,
    the emission weighted by Alpha in the mix; Alpha 1 leaves the Principled BSDF alone."""
    m, nt, out = scenes._node_material("Half")
    p = nt.nodes.new("ShaderNodeBsdfPrincipled")
    p.inputs["Alpha"].default_value = 0.25
    p.inputs["Emission"].default_value = (1.0, 0.5, 0.25, 1.0)
    p.inputs["Emission Strength"].default_value = 2.0
    nt.links.new(p.outputs[0], out.inputs["Surface"])
    d, table, warnings = export_material(m)
    assert not warnings and "alpha" not in d
    assert d["type"] == "mix" and d["factor"] == 0.25
    assert table[d["a"]] == {"type": "transparent", "color": [1.0, 1.0, 1.0]}
    assert table[d["b"]]["type"] == "principled" and "emission" not in table[d["b"]]
    assert d["emission"] == pytest.approx([0.5, 0.25, 0.125]) and d["strength"] == 1.0
    p.inputs["Alpha"].default_value = 1.0
    assert export_material(m)[0]["type"] == "principled"
    # Linked: the factor is the (clamped) link.
    d = export_material(alpha_leaf_material("LinkedLeaf", str(out_dir)))[0]
    assert d["type"] == "mix" and isinstance(d["factor"], dict)
    fac = d["nodes"][d["factor"]["link"]]
    assert fac["props"] == {"operation": "ADD", "use_clamp": True}
    assert fac["inputs"]["Value"]["output"] == "Alpha"


# (sppm with Transparent 1 reads 0.975 of Cycles: the World's light reaching the floor through
# the leaf after the camera's transparent pass is left to next-event estimation, which that
# budget blocks, while Cycles' BSDF rays still find part of it; photons that only crossed the
# leaf are direct light, not stored. Not checked.)
@pytest.mark.parametrize("method,transparent", [("pt", 8), ("pt", 1), ("sppm", 8)])
def test_leaf_with_an_alpha_texture_renders_as_cycles(empty_scene, out_dir, method, transparent):
    """The leaf, the floor through its open cells and its shadow: image mean and each channel
    within 1.5 % of Cycles' (64 samples each). With Light Paths > Transparent 1 a pass through the
    leaf is a transparent bounce as in Cycles: the camera ray sees only the emission of the floor
    behind it (none: black) and shadow rays cross no leaf (an opaque shadow); the old stochastic
    cut-out let every ray through there (as bright as with 8: 1.12 of Cycles, measured on main
    e818fe0, as the sppm leaf at 8 read 0.82 before trace_eye let its eye paths through)."""
    leaf_scene(empty_scene, str(out_dir))
    samples = 64
    scenes.configure_cycles(empty_scene, samples, 8)
    empty_scene.cycles.transparent_max_bounces = transparent
    cycles, _ = _rgba(empty_scene, os.path.join(str(out_dir), f"alpha_leaf_cycles_{transparent}.exr"))
    empty_scene.render.engine = 'GRADPHOTON'
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes = method, 'PASSES', samples
    if method == "pt":
        g.pt.max_bounces = 8
    else:
        g.sppm.use_auto_photons, g.sppm.photons = False, 20000
    ours, _ = _rgba(empty_scene, os.path.join(str(out_dir), f"alpha_leaf_{method}_{transparent}.exr"))
    ratio = ours.sum() / cycles.sum()
    per_channel = ours.reshape(-1, 3).mean(0) / cycles.reshape(-1, 3).mean(0)
    print(f"ALPHA LEAF {method}, transparent bounces {transparent}: gradphoton/cycles = {ratio:.4f}, per channel "
          f"{per_channel.round(4)}; gradphoton {ours.reshape(-1, 3).mean(0).round(4)}, "
          f"cycles {cycles.reshape(-1, 3).mean(0).round(4)}")
    assert abs(ratio - 1) < 0.015, ratio
    assert np.all(np.abs(per_channel - 1) < 0.015), per_channel


def pane_scene(scene, color):
    """A Transparent BSDF pane of `color` filling the view before a blue World, and a grey
    diffuse card behind it in the view's left part."""
    scenes.set_world(scene, (0.2, 0.4, 1.0), 1.0)
    m, nt, out = scenes._node_material("Pane")
    t = nt.nodes.new("ShaderNodeBsdfTransparent")
    t.inputs["Color"].default_value = (*color, 1.0)
    nt.links.new(t.outputs[0], out.inputs["Surface"])
    scenes.add_plane(scene, "Pane", 20.0, m, (0, 0, 2))
    scenes.add_plane(scene, "Card", 1.5, scenes.diffuse_material("Card", (0.5, 0.5, 0.5)), (-1.0, 0, 0))
    scenes.add_camera(scene, (0, 0, 10), (0, 0, 0), lens=50.0)
    scene.render.resolution_x, scene.render.resolution_y = 32, 24
    scene.render.film_transparent = True


# The spectral methods average the RGB colour of the closures passed, as Cycles (RgbTransparency,
# native/integrators/paths/medium_walk.h): before, the throughput's mean over the path's
# wavelengths, with which this test read alpha 0.427 (spt), 0.426 (spt-hero) and 0.423 (spectral
# sppm) for a red pane's 2/3, 0.706, 0.705, 0.705 for the other's 1/2.
@pytest.mark.parametrize("method,spectral", [("pt", "auto"), ("sppm", "auto"), ("spt", "spectral"),
                                             ("spt-hero", "spectral"), ("sppm", "spectral")])
@pytest.mark.parametrize("color", [(1.0, 0.0, 0.0), (0.2, 0.9, 0.4)])
def test_film_transparent_through_a_tinted_pane_is_cycles(empty_scene, out_dir, method, spectral, color):
    """Cycles: alpha 1 - mean(colour) (2/3 for red) and no colour where the camera sees the World
    through the pane; the card behind it opaque (alpha 1) and tinted. Alpha per pixel (away from
    the card's edges) and the card's colour against Cycles' render (the RGB methods within 3 %;
    the spectral ones' colour is that of the upsampled spectra's product, not checked). Before:
    alpha 0 there (the share of samples that hit the scene)."""
    pane_scene(empty_scene, color)
    scenes.configure_cycles(empty_scene, 16, 8)
    tag = "_".join(f"{c:g}" for c in color)
    c_rgb, c_a = _rgba(empty_scene, os.path.join(str(out_dir), f"pane_{tag}_cycles.exr"))
    expected = 1.0 - sum(color) / 3.0
    empty_scene.render.engine = 'GRADPHOTON'
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes = method, 'PASSES', 16
    g.spectral_mode = spectral
    if method == "sppm":
        g.sppm.use_auto_photons, g.sppm.photons = False, 5000
    rgb, a = _rgba(empty_scene, os.path.join(str(out_dir), f"pane_{tag}_{method}_{spectral}.exr"))
    world = np.abs(c_a - expected) < 1e-4  # Cycles: the World seen through the pane
    card = c_a == 1.0
    print(f"PANE {color} {method} ({spectral}): Cycles alpha {expected:.5f} on {world.sum()} pixels, 1 on "
          f"{card.sum()}; gradphoton alpha there {a[world].mean():.5f} [{a[world].min():.5f}, {a[world].max():.5f}] "
          f"and {a[card].mean():.5f}; colour on the World's pixels {rgb[world].max():.5f} (Cycles "
          f"{c_rgb[world].max():.5f}); card {rgb[card].mean(0).round(4)} (Cycles {c_rgb[card].mean(0).round(4)})")
    assert world.sum() > 400 and card.sum() > 20
    assert np.abs(a[world] - expected).max() < 1e-4
    assert np.abs(a[card] - 1.0).max() < 1e-4
    assert rgb[world].max() == 0.0 and c_rgb[world].max() == 0.0
    if spectral != "spectral":
        assert np.allclose(rgb[card].mean(0), c_rgb[card].mean(0), rtol=0.03, atol=1e-3)
