"""Principled glass colour and GGX masking as Cycles 3.4 computes them (issue 30).

Coloured Principled glass: Cycles 3.4 (svm/closure.h) weights the refraction closure by the Base
Color and leaves the reflection closure white, blended toward the Base Color by Specular Tint
through interpolate_fresnel_color; the exporter writes the dielectric's "specular_tint" for it
(the Glass BSDF tints both). A red glass sphere (the test_rough_glass scene) shows it in its blue
and green channels, where the reflection is most of the light.

GGX masking: Cycles 3.4's GGX reflection (bsdf_microfacet.h) masks by the separable G1(wo) G1(wi);
the exporter writes "masking": "separable" (the core's default is height-correlated). A rough
Glossy sphere under a point light in a grey world shows it at its rim.

Per-channel means within MEAN_TOL (the issue's 1 %), relMSE below a bound about twice the largest
measured (docs/blender.md has the numbers). Seen failing on main's behaviour (the exporter's keys
dropped): the red glass's G and B 0.64-0.86 of Cycles', relMSE 0.022-0.071; the roughness 0.8
sphere 1.0149 (relMSE 1.1e-3). Roughness 0.5 passes either way (the G differ by 0.1 % there)."""
import pytest

import scenes
from test_cycles_brightness import relmse, render_both
from test_rough_glass import glass_scene

MEAN_TOL = 0.01
GLASS_SIZE, GLASS_SAMPLES, GLASS_RELMSE = (64, 48), 1024, 0.012  # measured 0.0037-0.0054
METAL_SIZE, METAL_SAMPLES, METAL_RELMSE = (48, 36), 512, 6e-4  # measured 2.4e-4

RED = (0.8, 0.15, 0.05, 1.0)
GLASS_CASES = {
    "principled_red_glass_ggx_0.3": {"Roughness": 0.3, "IOR": 1.45, "Transmission": 1.0, "Base Color": RED},
    "principled_red_glass_smooth": {"Roughness": 0.0, "IOR": 1.45, "Transmission": 1.0, "Base Color": RED},
    "principled_red_glass_tint_0.7": {"Roughness": 0.3, "IOR": 1.45, "Transmission": 1.0, "Base Color": RED,
                                      "Specular Tint": 0.7},
}


def channel_ratios(ours, cycles):
    return ours.reshape(-1, 3).sum(0) / cycles.reshape(-1, 3).sum(0)


@pytest.mark.parametrize("case", sorted(GLASS_CASES))
def test_coloured_principled_glass_against_cycles(empty_scene, out_dir, case):
    glass_scene(empty_scene, "ShaderNodeBsdfPrincipled", 'GGX', GLASS_CASES[case])
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = GLASS_SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=GLASS_SAMPLES, bounces=8)
    ratios = channel_ratios(ours, cycles)
    err = relmse(ours, cycles)
    print(f"GLASSCYCLES {case}: gradphoton/cycles per channel = {ratios.round(4)}, relMSE {err:.5f}")
    assert cycles.sum() > 1e-3
    assert all(abs(r - 1) < MEAN_TOL for r in ratios), f"{case}: gradphoton/Cycles per channel = {ratios}"
    assert err < GLASS_RELMSE, f"{case}: relMSE {err:.5f}"


def metal_sphere(scene, roughness):
    m = scenes.closure_material("Metal", "ShaderNodeBsdfGlossy", 'GGX',
                                {"Roughness": roughness, "Color": (0.9, 0.7, 0.5, 1.0)})
    scenes.sphere_on_grey_floor(scene, m, (0, -2.6, 1.2), (0, 0, 1.0))


@pytest.mark.parametrize("roughness", [0.5, 0.8])
def test_rough_metal_masking_against_cycles(empty_scene, out_dir, roughness):
    metal_sphere(empty_scene, roughness)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = METAL_SIZE
    case = f"metal_ggx_{roughness}"
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=METAL_SAMPLES, bounces=4)
    ratio = ours.sum() / cycles.sum()
    h, w = ours.shape[:2]
    c = (slice(h // 6, 5 * h // 6), slice(w // 4, 3 * w // 4))  # the sphere, its rim included
    sphere = ours[c].sum() / cycles[c].sum()
    err = relmse(ours, cycles)
    print(f"GLASSCYCLES {case}: gradphoton/cycles = {ratio:.4f}, sphere {sphere:.4f}, relMSE {err:.5f}")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < MEAN_TOL, f"{case}: gradphoton/Cycles = {ratio:.4f}"
    assert abs(sphere - 1) < MEAN_TOL, f"{case}: sphere gradphoton/Cycles = {sphere:.4f}"
    assert err < METAL_RELMSE, f"{case}: relMSE {err:.5f}"


def test_exporter_writes_principled_glass_and_masking(empty_scene):
    from gradphoton.export.material import MaterialExporter
    from gradphoton.export.warnings import Warnings
    table, w = {}, Warnings()
    glass = MaterialExporter(table, w).convert(
        scenes.closure_material("G", "ShaderNodeBsdfPrincipled", 'GGX', GLASS_CASES["principled_red_glass_tint_0.7"]))
    assert glass["type"] == "dielectric" and glass["specular_tint"] == pytest.approx(0.7), glass
    plain = MaterialExporter(table, w).convert(
        scenes.closure_material("B", "ShaderNodeBsdfGlass", 'GGX', {"Roughness": 0.3}))
    assert "specular_tint" not in plain, plain  # the Glass BSDF tints its reflection
    for dist, separable in (('GGX', True), ('BECKMANN', False), ('MULTI_GGX', False)):
        d = MaterialExporter(table, w).convert(
            scenes.closure_material("M", "ShaderNodeBsdfGlossy", dist, {"Roughness": 0.5}))
        assert (d.get("masking") == "separable") == separable, (dist, d)
    assert not w, w.lines()
