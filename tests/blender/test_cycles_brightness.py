"""Same .blend, Cycles and gradphoton: a diffuse floor lit by one light of each kind must render
at the same mean brightness (within 3%). This pins the unit conversions in export/light.py and
export/material.py to Cycles' conventions."""
import os

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import native

CASES = list(scenes.LIGHT_CASES) + ["emissive_mesh", "world"]
SIZE = (48, 36)


def mean_rgb(path):
    img = native.get().read_exr(path)["combined"]
    return img.reshape(-1, img.shape[-1])[:, :3].mean(0)


def render_both(scene, out_dir, case, samples=32):
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scenes.configure_cycles(scene, samples)
    cycles = mean_rgb(scenes.render_to_exr(scene, os.path.join(out_dir, f"{case}_cycles.exr")))
    scene.render.engine = 'GRADPHOTON'
    scene.gradphoton.method = 'pt'
    scene.gradphoton.stop_rule = 'PASSES'
    scene.gradphoton.passes = samples
    scene.gradphoton.max_bounces = 4  # the core's max_depth 6
    ours = mean_rgb(scenes.render_to_exr(scene, os.path.join(out_dir, f"{case}_gradphoton.exr")))
    return ours, cycles


@pytest.mark.parametrize("case", CASES)
def test_same_brightness_as_cycles(empty_scene, out_dir, case):
    scenes.brightness_scene(empty_scene, case)
    ours, cycles = render_both(empty_scene, str(out_dir), case)
    ratio = ours.sum() / cycles.sum()
    print(f"BRIGHTNESS {case}: gradphoton/cycles = {ratio:.4f} (gradphoton {ours.round(4)}, cycles {cycles.round(4)})")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < 0.03, f"{case}: gradphoton/Cycles mean = {ratio:.4f}"
