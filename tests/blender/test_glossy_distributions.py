"""Glossy BSDF distributions (Beckmann, Ashikhmin-Shirley; GGX as the control) against Cycles
3.4 in this Blender: a glossy floor (roughness 0.3 and 0.6) lit by an area light whose
highlight is in view, under a dim grey World; path tracing, the same samples and bounces.
Means within MEAN_TOL (the issue's 1 %), relMSE below a bound about twice what was measured
(docs/blender.md)."""
import pytest

import scenes
from test_cycles_brightness import relmse, render_both

SIZE = (48, 36)
MEAN_TOL = 0.01  # the 1 %; measured (2026-11-27) 0.9996-1.0031, GGX's own 1.0015 / 1.0000 (separable masking)
RELMSE = 0.016   # measured at most 0.0082


def glossy_floor(scene, distribution, roughness):
    m, nt, out = scenes._node_material("Glossy")
    g = nt.nodes.new("ShaderNodeBsdfGlossy")
    g.distribution = distribution
    g.inputs["Roughness"].default_value = roughness
    g.inputs["Color"].default_value = (0.8, 0.6, 0.4, 1)
    nt.links.new(g.outputs[0], out.inputs["Surface"])
    scenes.add_plane(scene, "Floor", 8.0, m)
    light = scenes.add_light(scene, "Area", 'AREA', 'SQUARE', 200.0, {"size": 1.0}, (0, 2.0, 2.0))
    scenes.look_at(light, (0, 0, 0))
    scenes.set_world(scene, (0.5, 0.5, 0.5), 0.2)
    scenes.add_camera(scene, (0, -3.0, 2.0), (0, 0.5, 0), lens=35.0)


@pytest.mark.parametrize("distribution", ['GGX', 'BECKMANN', 'ASHIKHMIN_SHIRLEY'])
@pytest.mark.parametrize("roughness", [0.3, 0.6])
def test_glossy_distribution_against_cycles(empty_scene, out_dir, distribution, roughness):
    glossy_floor(empty_scene, distribution, roughness)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = SIZE
    case = f"glossy_{distribution.lower()}_{roughness}"
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=128, bounces=2)
    ratio = ours.sum() / cycles.sum()
    err = relmse(ours, cycles)
    print(f"GLOSSY {distribution} roughness {roughness}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f}")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < MEAN_TOL, f"{case}: gradphoton/Cycles = {ratio:.4f}"
    assert err < RELMSE, f"{case}: relMSE {err:.5f}"
