"""Anisotropic glossy lobes against Cycles 3.4 in this Blender (issue 30, Closures): the
Anisotropic BSDF (GGX, Beckmann; Anisotropy of both signs, a Rotation) and Principled's
Anisotropic (+ Rotation) on a floor whose default tangent (Cycles' radial one about the
object's Z axis) circles the floor's centre, lit by an area light whose highlight is in view,
under a dim grey World; path tracing, the same samples and bounces. Means within MEAN_TOL,
relMSE below a bound about twice what was measured (docs/blender.md)."""
import pytest

import scenes
from test_cycles_brightness import relmse, render_both

SIZE = (48, 36)
MEAN_TOL = 0.015
RELMSE = 0.03
SAMPLES = 512

# case -> (node, distribution, inputs)
CASES = {
    "ggx_0.8": ("ShaderNodeBsdfAnisotropic", 'GGX', {"Roughness": 0.4, "Anisotropy": 0.8}),
    "ggx_-0.6_rotated": ("ShaderNodeBsdfAnisotropic", 'GGX', {"Roughness": 0.4, "Anisotropy": -0.6, "Rotation": 0.15}),
    "beckmann_0.7": ("ShaderNodeBsdfAnisotropic", 'BECKMANN', {"Roughness": 0.4, "Anisotropy": 0.7}),
    "principled_metal": ("ShaderNodeBsdfPrincipled", 'GGX', {"Base Color": (0.9, 0.7, 0.5, 1), "Metallic": 1.0,
                                                             "Roughness": 0.5, "Anisotropic": 0.9}),
}


def anisotropic_floor(scene, kind, distribution, inputs, world_only=False):
    m, nt, out = scenes._node_material("Aniso")
    g = nt.nodes.new(kind)
    g.distribution = distribution
    if kind == "ShaderNodeBsdfAnisotropic":
        g.inputs["Color"].default_value = (0.8, 0.6, 0.4, 1)
    for k, v in inputs.items():
        g.inputs[k].default_value = v
    nt.links.new(g.outputs[0], out.inputs["Surface"])
    scenes.add_plane(scene, "Floor", 8.0, m, location=(0.5, 1.0, 0))
    if world_only:
        scenes.set_world(scene, (0.5, 0.6, 0.7), 1.0)
    else:
        light = scenes.add_light(scene, "Area", 'AREA', 'SQUARE', 200.0, {"size": 1.0}, (0, 2.0, 2.0))
        scenes.look_at(light, (0, 0, 0))
        scenes.set_world(scene, (0.5, 0.5, 0.5), 0.2)
    scenes.add_camera(scene, (0, -3.0, 2.0), (0, 0.5, 0), lens=35.0)


# Cycles 3.4 draws anisotropic Beckmann normals as if isotropic of alpha_x (bsdf_microfacet.h's
# beckmann_sample passes alpha_x twice) while weighting them by the anisotropic density, so its
# image is not the lobe it evaluates: measured 0.916 (World only: 0.959). Not compared here; the
# unit tests check the lobe against the formulas (docs/blender.md).
CYCLES_BIASED = {"beckmann_0.7"}


@pytest.mark.parametrize("case", sorted(set(CASES) - CYCLES_BIASED))
def test_anisotropic_against_cycles(empty_scene, out_dir, case):
    anisotropic_floor(empty_scene, *CASES[case], world_only=case.endswith("_world"))
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), f"anisotropic_{case}", samples=SAMPLES, bounces=2)
    ratio = ours.sum() / cycles.sum()
    err = relmse(ours, cycles)
    print(f"ANISOTROPIC {case}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f}")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < MEAN_TOL, f"{case}: gradphoton/Cycles = {ratio:.4f}"
    assert err < RELMSE, f"{case}: relMSE {err:.5f}"
