"""Rough Glass BSDF as Cycles 3.4 renders it (issue 30: "Glass BSDF, GGX roughness 0.175, point
light of radius 0.25, grey world: 5 % too bright"). Cycles 3.4 (svm/closure.h) builds a Glass
BSDF of GGX, Beckmann or Sharp as two closures: a reflection without Fresnel weighted by F and a
refraction without Fresnel weighted by 1 - F, F the dielectric Fresnel at the shading normal for
the camera-side direction; the exporter writes "fresnel": "normal" and the core's dielectric
weights its lobes so (Material::fresnel_at_normal). Walter et al.'s Fresnel per microfacet (the
scene format's default) renders the sphere brighter.

A glass sphere filling most of the frame on a grey floor under a small point light (radius
0.25, as the issue's scene) and a grey World; path tracing, the same samples and bounces. The
image mean and the mean of the frame's centre (the sphere's interior, where the Fresnel
weighting shows) within MEAN_TOL (the issue's 1 %); relMSE below a bound about twice the
largest measured (docs/blender.md). Seen failing with Walter's per-microfacet Fresnel (the
exporter's "fresnel" key dropped): GGX 0.5 centre 1.0126."""
import pytest

import scenes
from test_cycles_brightness import relmse, render_both

SIZE = (64, 48)
SAMPLES = 1024
MEAN_TOL = 0.01
RELMSE = 0.03  # measured 0.008-0.014 (below)

# case -> (node, distribution, inputs)
CASES = {
    "glass_ggx_0.175": ("ShaderNodeBsdfGlass", 'GGX', {"Roughness": 0.175, "IOR": 1.45}),
    "glass_ggx_0.5": ("ShaderNodeBsdfGlass", 'GGX', {"Roughness": 0.5, "IOR": 1.45}),
    "glass_ggx_0.7": ("ShaderNodeBsdfGlass", 'GGX', {"Roughness": 0.7, "IOR": 1.45}),
    "glass_beckmann_0.3": ("ShaderNodeBsdfGlass", 'BECKMANN', {"Roughness": 0.3, "IOR": 1.45}),
    "principled_glass_ggx_0.5": ("ShaderNodeBsdfPrincipled", 'GGX',
                                   {"Roughness": 0.5, "IOR": 1.45, "Transmission": 1.0,
                                    "Base Color": (1, 1, 1, 1)}),
}


def glass_scene(scene, kind, distribution, inputs):
    m = scenes.closure_material("Glass", kind, distribution, inputs)
    scenes.sphere_on_grey_floor(scene, m, (0, -2.3, 1.2), (0, 0, 0.95))


@pytest.mark.parametrize("case", sorted(CASES))
def test_rough_glass_against_cycles(empty_scene, out_dir, case):
    glass_scene(empty_scene, *CASES[case])
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=SAMPLES, bounces=8)
    ratio = ours.sum() / cycles.sum()
    h, w = ours.shape[:2]
    c = (slice(h // 4, 3 * h // 4), slice(w // 3, 2 * w // 3))
    centre = ours[c].sum() / cycles[c].sum()
    err = relmse(ours, cycles)
    print(f"ROUGHGLASS {case}: gradphoton/cycles = {ratio:.4f}, centre {centre:.4f}, relMSE {err:.5f}")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < MEAN_TOL, f"{case}: gradphoton/Cycles = {ratio:.4f}"
    assert abs(centre - 1) < MEAN_TOL, f"{case}: centre gradphoton/Cycles = {centre:.4f}"
    assert err < RELMSE, f"{case}: relMSE {err:.5f}"


@pytest.mark.parametrize("case", sorted(CASES))
def test_exporter_writes_the_glass_split(empty_scene, case):
    """Glass and Principled glass of GGX / Beckmann carry Cycles' split, Multiscatter GGX not."""
    from gradphoton.export.material import MaterialExporter
    from gradphoton.export.warnings import Warnings
    kind, distribution, inputs = CASES[case]
    for dist, split in ((distribution, True), ('MULTI_GGX', False)):
        m = scenes.closure_material("M", kind, dist, inputs)
        table, w = {}, Warnings()
        d = MaterialExporter(table, w).convert(m)
        assert d["type"] == "dielectric", d
        assert (d.get("fresnel") == "normal") == split, (dist, d)
        assert not w, w.lines()
