"""Multiscatter GGX (Glossy, Glass, Principled) and Beckmann glass (Glass, Refraction) against
Cycles 3.4 in this Blender (issue 30): a sphere of the material on a grey floor under a grey
World and an area light; path tracing, the same samples and bounces. Means within MEAN_TOL (the
issue's 1 %), relMSE below a bound about twice what was measured (docs/blender.md). The Glossy
cases are white: Cycles 3.4's multiscatter eval weights a coloured walk's k-th later scattering
by colour^(2k+1) where its sampler has colour^(k+1) (bsdf_microfacet_multi_impl.h), so a
coloured one differs between its light sampling and its BSDF sampling; gradphoton keeps the
sampler's (bsdf.cpp)."""
import pytest

import bpy
import scenes
from test_cycles_brightness import relmse, render_both

SIZE = (48, 36)
MEAN_TOL = 0.01  # the 1 %; measured at 48x36, 512 samples, 8 bounces (at 128 the rough glass read 1.0058 and 1.0108 by seed alone; 1.0014 at 1024)
# relMSE bounds about twice what was measured; the glass spheres' caustics on the floor are noisy.
RELMSE = {"glossy": 0.03, "principled": 0.03, "refraction": 0.035, "glass": 0.15}

# case -> (node, distribution, inputs). Measured gradphoton / Cycles mean, relMSE (two runs):
#   glossy_multi_0.3 1.0007 / 0.9978 0.012, glossy_multi_0.8 0.9984 / 0.9978 0.011,
#   principled_metal_multi_0.6 0.9920 / 0.9903 0.0082 (the closest to the bound: headroom 0.1 %),
#   glass_beckmann_0.3 1.0062 0.044, refraction_beckmann_0.3 1.0017 0.017; the GGX
#   controls glossy_ggx_0.8 1.0025 0.008, glass_ggx_0.5 1.0058 0.073. With the walk's eval
#   stopped after its first scattering, glossy_multi_0.8 gave 0.9146 and the metal 0.9553; with
#   Beckmann glass's pdf of alpha 1.05 x, glass_beckmann 1.0105.
CASES = {
    "glossy_multi_0.3": ("ShaderNodeBsdfGlossy", 'MULTI_GGX', {"Roughness": 0.3, "Color": (1, 1, 1, 1)}),
    "glossy_multi_0.8": ("ShaderNodeBsdfGlossy", 'MULTI_GGX', {"Roughness": 0.8, "Color": (1, 1, 1, 1)}),
    "glass_multi_0.5": ("ShaderNodeBsdfGlass", 'MULTI_GGX', {"Roughness": 0.5, "IOR": 1.5}),
    "glass_ggx_0.5": ("ShaderNodeBsdfGlass", 'GGX', {"Roughness": 0.5, "IOR": 1.5}),
    "glossy_ggx_0.8": ("ShaderNodeBsdfGlossy", 'GGX', {"Roughness": 0.8, "Color": (1, 1, 1, 1)}),
    "glass_beckmann_0.3": ("ShaderNodeBsdfGlass", 'BECKMANN', {"Roughness": 0.3, "IOR": 1.5}),
    "refraction_beckmann_0.3": ("ShaderNodeBsdfRefraction", 'BECKMANN', {"Roughness": 0.3, "IOR": 1.5}),
    "principled_metal_multi_0.6": ("ShaderNodeBsdfPrincipled", 'MULTI_GGX',
                                   {"Roughness": 0.6, "Metallic": 1.0, "Base Color": (0.9, 0.9, 0.9, 1)}),
}


def sphere_scene(scene, kind, distribution, inputs):
    m = scenes.closure_material("Sphere", kind, distribution, inputs)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=1.0, location=(0, 0, 1))
    bpy.ops.object.shade_smooth()
    bpy.context.active_object.data.materials.append(m)
    scenes.add_plane(scene, "Floor", 8.0, scenes.diffuse_material("Floor", (0.5, 0.5, 0.5)))
    light = scenes.add_light(scene, "Area", 'AREA', 'SQUARE', 300.0, {"size": 1.0}, (1.5, -1.0, 3.5))
    scenes.look_at(light, (0, 0, 1))
    scenes.set_world(scene, (0.6, 0.6, 0.6), 1.0)
    scenes.add_camera(scene, (0, -4.5, 1.6), (0, 0, 0.9), lens=35.0)


# Cycles 3.4's Multiscatter GGX glass renders this sphere as its single-scattering GGX glass does
# (mean 0.6561 against 0.6535): its walk loses what single scattering loses (its sampler drops
# walks where its stand-in pdf is 0, and keeps C1 across the interface); gradphoton's keeps the
# energy (white furnace 0.999-1.000, bsdf_test.cpp) and is 7.4 % brighter (relMSE 0.13).
KNOWN = {"glass_multi_0.5": "Cycles 3.4's multiscatter glass evaluates a lossier BSDF than it samples, so its image "
                            "depends on its light sampling; ours is consistent (docs/blender.md)"}


@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.xfail(strict=True, reason=KNOWN[c])) if c in KNOWN
                                  else c for c in sorted(CASES)])
def test_multiscatter_and_beckmann_against_cycles(empty_scene, out_dir, case):
    sphere_scene(empty_scene, *CASES[case])
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), case, samples=512, bounces=8)
    ratio = ours.sum() / cycles.sum()
    err = relmse(ours, cycles)
    print(f"MULTISCATTER {case}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f}")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < MEAN_TOL, f"{case}: gradphoton/Cycles = {ratio:.4f}"
    bound = RELMSE[case.split("_")[0]]
    assert err < bound, f"{case}: relMSE {err:.5f}"


@pytest.mark.parametrize("case", ["glossy_multi_0.8", "glass_beckmann_0.3", "principled_metal_multi_0.6"])
def test_exporter_writes_the_distribution(empty_scene, case):
    """The distribution reaches the core's material, with no warning."""
    from gradphoton.export.material import MaterialExporter
    from gradphoton.export.warnings import Warnings
    kind, distribution, inputs = CASES[case]
    m = scenes.closure_material("M", kind, distribution, inputs)
    table, w = {}, Warnings()
    d = MaterialExporter(table, w).convert(m)
    assert d["distribution"] == {'MULTI_GGX': "multi_ggx", 'BECKMANN': "beckmann"}[distribution]
    assert not w, w.lines()
