"""Same .blend, Cycles and gradphoton (path tracing): a scene lit by each kind of light must
render at Cycles' mean brightness, within 0.5 %, and agree pixel by pixel (relMSE below a
measured bound). This pins the unit conversions and the light conventions of export/light.py,
export/visibility.py and export/material.py to Cycles 3.4's.

Two families of scenes:
  - a diffuse floor seen from above, lit by one light of each kind placed out of view
    (scenes.LIGHT_CASES, an emissive mesh, the world);
  - the Cornell room (Diffuse BSDF walls) lit from just under the ceiling, the light in view
    (scenes.CORNELL_LIGHTS, an emissive mesh): the light object is not shown to the camera
    (Blender 3.4's default), it casts no shadow and rays pass through it, as in Cycles.

Means are compared as sums of R, G, B over the image. relMSE = mean over pixels of
(ours - cycles)^2 / (cycles^2 + 0.01), both images noisy; the bounds are about twice what was
measured (docs/blender.md gives the figures)."""
import os

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import native

FLOOR_CASES = list(scenes.LIGHT_CASES) + ["emissive_mesh", "world"]
CORNELL_CASES = list(scenes.CORNELL_LIGHTS) + ["emissive_mesh", "area_camera_visible"]
FLOOR_SIZE, CORNELL_SIZE = (48, 36), (48, 48)
MEAN_TOLERANCE = 0.005
# relMSE bounds: about twice the relMSE measured at these sizes and sample counts (both images
# noisy; the renders are seeded, so the figures repeat): floor cases 0.00001 (point) to 0.0009
# (world); Cornell area 0.0025, point 0.012, spot 0.0038, sun 0.0016, emissive mesh 0.024 (its
# edges in view), area shown to the camera 0.0027.
FLOOR_RELMSE = 0.002
CORNELL_RELMSE = {"area": 0.005, "area_disk": 0.005, "point": 0.025, "spot": 0.008, "sun": 0.004,
                  "emissive_mesh": 0.05, "area_camera_visible": 0.006}


def read_rgb(path):
    img = native.get().read_exr(path)["combined"]
    return img[..., :3].astype(np.float64)


def relmse(ours, ref):
    return float(np.mean((ours - ref) ** 2 / (ref ** 2 + 0.01)))


def render_both(scene, out_dir, case, samples, bounces):
    scenes.configure_cycles(scene, samples, bounces)
    cycles = read_rgb(scenes.render_to_exr(scene, os.path.join(out_dir, f"{case}_cycles.exr")))
    scene.render.engine = 'GRADPHOTON'
    g = scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', samples, bounces
    ours = read_rgb(scenes.render_to_exr(scene, os.path.join(out_dir, f"{case}_gradphoton.exr")))
    return ours, cycles


def check(ours, cycles, case, bound, mean_tolerance=MEAN_TOLERANCE):
    ratio = ours.sum() / cycles.sum()
    err = relmse(ours, cycles)
    print(f"BRIGHTNESS {case}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f} "
          f"(gradphoton {ours.reshape(-1, 3).mean(0).round(4)}, cycles {cycles.reshape(-1, 3).mean(0).round(4)})")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < mean_tolerance, f"{case}: gradphoton/Cycles mean = {ratio:.4f}"
    assert err < bound, f"{case}: relMSE {err:.5f} >= {bound}"


@pytest.mark.parametrize("case", FLOOR_CASES)
def test_floor_same_brightness_as_cycles(empty_scene, out_dir, case):
    scenes.brightness_scene(empty_scene, case)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = FLOOR_SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=64, bounces=4)
    check(ours, cycles, case, FLOOR_RELMSE)


@pytest.mark.parametrize("case", CORNELL_CASES)
def test_cornell_same_brightness_as_cycles(empty_scene, out_dir, case):
    visible = case == "area_camera_visible"
    scenes.cornell_lit(empty_scene, "area" if visible else case)
    if visible:
        bpy.data.objects["area"].visible_camera = True
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = CORNELL_SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=256, bounces=8)
    check(ours, cycles, case, CORNELL_RELMSE[case])
    if case == "area":  # the light's pixels show the ceiling, not a white square
        assert cycles.max() < 5 and ours.max() < 5


# Materials against Cycles 3.4 (same Cornell room and area light, the floor and back wall of
# each material). Mix and Add of Diffuse and Glossy, and the Principled BSDF (the core's
# `principled`: Cycles' Burley diffuse plus GGX specular, added; its metal a conductor with
# Cycles' interpolated Fresnel), are Cycles' own closures: within 0.5 % (metal 1 %: its
# highlights are noisy, our mean moves by 0.25 % between seeds at 1024 samples, Cycles' by
# 0.2 %). Measured (256 samples each): plastic roughness 0.5 1.0004 (relMSE 0.0018), 0.15 1.0024
# (0.0042), half metal 0.9998 (0.0034), metal 1.0043 (0.036). The dark metal (1024 samples:
# 1.0000, relMSE 0.00024; with other seeds 1.0009 and 0.9992) is what tells the Fresnel apart:
# with Schlick's (before) it rendered 0.9934 (other seeds 0.9942, 0.9927).
MATERIAL_RATIO = {"mix_shader": (0.995, 1.005), "add_shader": (0.995, 1.005), "principled_metal": (0.99, 1.01),
                  "principled_plastic": (0.995, 1.005), "principled_glossy_plastic": (0.995, 1.005),
                  "principled_half_metal": (0.995, 1.005), "principled_dark_metal": (0.997, 1.003)}
# relMSE bounds: about twice what was measured (metal: its highlights, pixel by pixel).
MATERIAL_RELMSE = {"mix_shader": 0.012, "add_shader": 0.026, "principled_metal": 0.07, "principled_plastic": 0.004,
                   "principled_glossy_plastic": 0.009, "principled_half_metal": 0.007, "principled_dark_metal": 0.0005}
MATERIAL_SAMPLES = {"principled_dark_metal": 1024}  # others 256


@pytest.mark.parametrize("case", list(scenes.CORNELL_MATERIALS))
def test_cornell_materials_against_cycles(empty_scene, out_dir, case):
    scenes.cornell_material(empty_scene, case)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = CORNELL_SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=MATERIAL_SAMPLES.get(case, 256), bounces=8)
    ratio, err = ours.sum() / cycles.sum(), relmse(ours, cycles)
    print(f"MATERIAL {case}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f}")
    low, high = MATERIAL_RATIO[case]
    assert low < ratio < high, f"{case}: gradphoton/Cycles mean = {ratio:.4f}, expected in ({low}, {high})"
    assert err < MATERIAL_RELMSE[case], f"{case}: relMSE {err:.5f} >= {MATERIAL_RELMSE[case]}"


# Per-kind ray visibility of lights (Object Properties > Visibility > Diffuse / Glossy), against
# Cycles 3.4: the Cornell room's floor and back wall a Mix of Diffuse and Glossy (as
# mix_shader), lit by a light hidden from one kind of bounce ray, so that light reaches the
# other lobe only (and, hidden from diffuse, nothing reaches the diffuse walls directly).
# gradphoton's path tracer honours the switches (native/integrators/path_tracer.cpp).
# Measured: area light hidden from diffuse 0.9994 (relMSE 0.0078) at 1024 samples (at 256
# 1.0069: the glossy-only light is noisy), point light hidden from glossy 1.0011 (0.0067) at 512
# (1.0025 at 256). Cycles' own mean moves by 0.05 % (area, 1024) and 0.2 % (point, 256) between
# seeds. The glossy-only area light's mean moves by 0.25 % between gradphoton's seeds at 1024
# samples (seeds 1-4 against Cycles at 4096: 1.0003, 0.9948, 0.9971, 0.9978; the same within
# 0.0005 without Russian roulette), so its mean is held to 1 % (4 of those), not 0.5 %.
VISIBILITY_CASES = {"area_hidden_from_diffuse": ("area", "visible_diffuse", 1024, 0.016, 0.01),
                    "point_hidden_from_glossy": ("point", "visible_glossy", 512, 0.014, MEAN_TOLERANCE)}


@pytest.mark.parametrize("case", list(VISIBILITY_CASES))
def test_light_ray_visibility_against_cycles(empty_scene, out_dir, case):
    light, switch, samples, bound, mean_tolerance = VISIBILITY_CASES[case]
    scenes.cornell_lit(empty_scene, light)
    mix = scenes.mix_material("Mix")
    for name in ("Floor", "Back"):
        me = bpy.data.objects[name].data
        me.materials.clear()
        me.materials.append(mix)
    setattr(bpy.data.objects[light], switch, False)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = CORNELL_SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=samples, bounces=8)
    check(ours, cycles, case, bound, mean_tolerance)


# World > Settings > Ray Visibility against Cycles 3.4: the floor scene's sky hidden from one kind
# of bounce ray over a floor that is a Mix (0.3) of Diffuse (0.7, 0.5, 0.3) and Glossy 0.8. Cycles
# does not sample a constant World as a light and lets a BSDF ray of a visible kind carry the
# whole f/pdf, so the other lobe's colour leaks into what the sky lights; gradphoton follows
# (native/integrators/lobe_split.h). Measured (256 samples, gradphoton seeds 1-3): hidden from
# glossy 0.9989-0.9991 (relMSE 0.0017; RGB (0.4171, 0.3669, 0.2824), Cycles' (0.4176, 0.3673,
# 0.2827)), from diffuse 1.0007-1.0017 (relMSE 0.0085: the glossy-only sky is noisy). The
# lights' rule (only the lobes that see it, gradphoton's before) gave 0.9926 with another
# colour, (0.441, 0.367, 0.252), and 1.0101. relMSE bounds about twice what was measured.
WORLD_CASES = {"world_hidden_from_glossy": ("glossy", 0.004), "world_hidden_from_diffuse": ("diffuse", 0.017)}


@pytest.mark.parametrize("case", list(WORLD_CASES))
def test_world_ray_visibility_against_cycles(empty_scene, out_dir, case):
    switch, bound = WORLD_CASES[case]
    scenes.brightness_scene(empty_scene, "world")
    floor = bpy.data.objects["Floor"].data
    floor.materials.clear()
    floor.materials.append(scenes.mix_material("Mix"))
    setattr(empty_scene.world.cycles_visibility, switch, False)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = FLOOR_SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=256, bounces=4)
    check(ours, cycles, case, bound)
