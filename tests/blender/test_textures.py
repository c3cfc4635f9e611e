"""Textures against Cycles 3.4, from the same .blend: a floor whose image drives a Diffuse
colour, a normal map, a Mix Shader's factor, or a Principled BSDF's base colour, roughness
and normal (scenes.textured_floor). Means within 0.5 % where the closures are Cycles' own (the
normal-map and Principled cases are held to bands around their measured ratios, see RATIO); relMSE (as test_cycles_brightness) below
about twice what was measured. Also: a missing image is one warning and renders magenta, a
packed image renders as its file does."""
import os

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import export
from test_cycles_brightness import read_rgb, relmse, render_both

SIZE = (48, 36)
# Measured (64 samples each, seeded), gradphoton/Cycles mean and relMSE: diffuse 1.0003 /
# 0.0046, mix 0.9973 / 0.0050, normal_map 1.043 / 0.0083, principled 1.021 / 0.19. Bounds:
# about twice the relMSE; means within 0.5 % where Cycles' closures are ours (diffuse, mix).
# Held to bands around the measured ratio, so a change shows (docs/blender.md):
#  - normal_map: lit by the sun alone it agrees within 2 % (relMSE 0.0009); the dim sky, which
#    also lights the floor from below its plane, comes out 11 % brighter than in Cycles, whose
#    bent-normal diffuse loses more of the sky than ours (not yet understood);
#  - principled: a Fresnel-weighted plastic by design (test_cycles_brightness: 0.94 untextured),
#    here with the normal map's excess on top; its sun highlights differ pixel by pixel.
RATIO = {"diffuse": (0.995, 1.005), "mix": (0.995, 1.005), "normal_map": (1.02, 1.07), "principled": (0.99, 1.06)}
RELMSE = {"diffuse": 0.01, "mix": 0.01, "normal_map": 0.02, "principled": 0.4}


@pytest.mark.parametrize("case", list(RATIO))
def test_textured_floor_against_cycles(empty_scene, out_dir, case):
    scenes.textured_floor(empty_scene, case, str(out_dir))
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=64, bounces=4)
    ratio = ours.sum() / cycles.sum()
    err = relmse(ours, cycles)
    print(f"TEXTURE {case}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f}")
    low, high = RATIO[case]
    assert low < ratio < high, f"{case}: gradphoton/Cycles mean = {ratio:.4f}, expected in ({low}, {high})"
    assert err < RELMSE[case], f"{case}: relMSE {err:.5f} >= {RELMSE[case]}"


def _export():
    return export.export_scene(bpy.context.evaluated_depsgraph_get())


def test_missing_image_is_a_warning_and_magenta(empty_scene, out_dir):
    scenes.textured_floor(empty_scene, "diffuse", str(out_dir))
    img = bpy.data.images["Pattern"]
    img.filepath = os.path.join(str(out_dir), "no_such_image.png")
    img.reload()
    ex = _export()
    assert any("image texture missing (magenta)" in line for line in ex.warnings.lines()), ex.warnings.lines()
    assert ex.description["materials"]["Textured"]["color"] == [1.0, 0.0, 1.0]
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 16, 12
    empty_scene.gradphoton.passes = 4
    rgb = np.asarray(read_rgb(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "magenta.exr"))))
    mean = rgb.reshape(-1, 3).mean(0)
    # Magenta lit by a bluish sky: no green, red and blue alike (within the sky's tint).
    assert mean[1] < 0.02 * mean[0] and abs(mean[0] - mean[2]) < 0.15 * mean[0], mean


def test_packed_image_renders_as_its_file(empty_scene, out_dir):
    scenes.textured_floor(empty_scene, "diffuse", str(out_dir))
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 16, 12
    empty_scene.gradphoton.passes = 4
    from_file = read_rgb(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "file.exr")))
    img = bpy.data.images["Pattern"]
    img.pack()
    os.remove(os.path.join(str(out_dir), "pattern.png"))
    ex = _export()
    tex = ex.description["materials"]["Textured"]["color"]
    assert isinstance(tex, dict) and os.path.isfile(tex["texture"]) and "gradphoton-images" in tex["texture"]
    assert not ex.warnings, ex.warnings.lines()
    packed = read_rgb(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "packed.exr")))
    np.testing.assert_allclose(packed, from_file, rtol=1e-5, atol=1e-6)


def test_textured_object_exports_its_render_uv_map(empty_scene, out_dir):
    scenes.textured_floor(empty_scene, "diffuse", str(out_dir))
    me = bpy.data.objects["Floor"].data
    other = me.uv_layers.new(name="Other")
    for loop in other.data:
        loop.uv = (0.5, 0.5)
    me.uv_layers["UVMap"].active_render = True
    me.uv_layers.active = other  # the editing map is not the one Cycles renders with
    ex = _export()
    floor = next(m for m in ex.meshes if m.name == "Floor")
    assert floor.uvs is not None and floor.uvs.max() == pytest.approx(2.0)
