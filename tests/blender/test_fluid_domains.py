"""Fluid (smoke) domains (export/fluid.py): a tiny gas domain baked in the test (resolution 16,
a few frames: about a second) exports its cache's density grid as a grid medium in the domain's
box and renders at Cycles' mean brightness; an unbaked domain is one warning naming it."""
import os

import bpy
import numpy as np

import scenes
from gradphoton import native
from gradphoton.export import export_scene
from test_volumes import volume_material


def export_current():
    return export_scene(bpy.context.evaluated_depsgraph_get())


def add_smoke(scene, cache_dir, material=None, bake=True, frames=4, location=(0, 0, 1.3), scale=(1.2, 1.0, 1.0),
              flow_type='SMOKE', smoke_color=None):
    """A 2 m cube domain (scaled, lifted) over a smoke emitter sphere (`flow_type` SMOKE, FIRE or
    BOTH; `smoke_color` the flow's colour), baked at resolution 16 for `frames` frames into
    cache_dir (the scene at the last frame)."""
    bpy.ops.mesh.primitive_cube_add(size=2, location=location)
    dom = bpy.context.active_object
    dom.name = "Domain"
    dom.scale = scale
    if material is not None:
        dom.data.materials.append(material)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, location=(location[0], location[1], location[2] - 0.6))
    flow = bpy.context.active_object
    flow.name = "Emitter"
    fm = flow.modifiers.new("Fluid", 'FLUID')
    fm.fluid_type = 'FLOW'
    fm.flow_settings.flow_type = flow_type
    if smoke_color is not None:
        fm.flow_settings.smoke_color = smoke_color
    fm.flow_settings.flow_behavior = 'INFLOW'
    flow.hide_render = True
    dm = dom.modifiers.new("Fluid", 'FLUID')
    dm.fluid_type = 'DOMAIN'
    ds = dm.domain_settings
    ds.domain_type = 'GAS'
    ds.resolution_max = 16
    ds.cache_directory = cache_dir
    ds.cache_type = 'ALL'
    ds.cache_frame_start, ds.cache_frame_end = 1, frames
    scene.frame_start, scene.frame_end = 1, frames
    if bake:
        with bpy.context.temp_override(object=dom, active_object=dom):
            assert bpy.ops.fluid.bake_all() == {'FINISHED'}
    scene.frame_set(frames)
    return dom


def test_unbaked_smoke_domain_is_one_warning_naming_it(empty_scene, out_dir):
    scenes.add_camera(empty_scene)
    add_smoke(empty_scene, os.path.join(str(out_dir), "cache"), bake=False)
    ex = export_current()
    lines = ex.warnings.lines()
    assert sum(line.startswith("fluid domain not baked (not rendered): Domain") for line in lines) == 1, lines
    assert not any(m.name.startswith("Domain") for m in ex.meshes)  # nor its mesh as a surface
    assert ex.build(native.get()) is not None


def test_baked_smoke_domain_exports_its_density_grid(empty_scene, out_dir):
    scenes.add_camera(empty_scene)
    pv = volume_material("Smoke", "ShaderNodeVolumePrincipled", **{"Density": 4.0, "Color": (0.8, 0.8, 0.8, 1)})
    add_smoke(empty_scene, os.path.join(str(out_dir), "cache"), pv)
    ex = export_current()
    d = ex.description
    name = "Domain [Smoke]"
    assert d["materials"][name] == {"type": "volume", "interior": name}
    g = d["media"][name]["grid"]
    assert g["file"].endswith(os.path.join("data", "fluid_data_0004.vdb")) and g["density_grid"] == "density"
    assert "color_grid" not in g and "smoke_color_grids" not in g
    # (Blender writes a flame grid, empty, for smoke without fire: Cycles' temperature from it is 0.)
    assert g.get("temperature_grid", "flame") == "flame"
    # The file's index space [0, resolution] lands on the domain's box in the world.
    m = np.array(g["transform"]["matrix"], dtype=np.float64).reshape(4, 4)
    info = {x["name"]: x for x in native.get().vdb_grids(g["file"])}["density"]
    dom = bpy.data.objects["Domain"].evaluated_get(bpy.context.evaluated_depsgraph_get())
    res = np.array(dom.modifiers["Fluid"].domain_settings.domain_resolution, dtype=np.float64)
    assert (res > 0).all(), res
    i2o = np.asarray(info["index_to_object"], dtype=np.float64)
    corner0 = (m @ i2o @ np.array([0, 0, 0, 1.0]))[:3]
    corner1 = (m @ i2o @ np.append(res, 1.0))[:3]
    np.testing.assert_allclose(corner0, [-1.2, -1.0, 0.3], atol=1e-4)
    np.testing.assert_allclose(corner1, [1.2, 1.0, 2.3], atol=1e-4)
    rec = [r for r in ex.meshes if r.name == name][0]
    assert rec.triangle_count == 12
    assert not any(line.startswith("fluid domain") for line in ex.warnings.lines()), ex.warnings.lines()
    assert ex.build(native.get()) is not None


def test_smoke_domain_at_cycles_brightness(empty_scene, out_dir):
    """A baked smoke plume (Principled Volume over the density grid) over a floor under a sun
    and a grey World: the image mean and the plume's window within 2 % of Cycles'."""
    scene = empty_scene
    scenes.set_world(scene, (0.5, 0.55, 0.6), 0.6)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    pv = volume_material("Smoke", "ShaderNodeVolumePrincipled", **{
        "Density": 8.0, "Color": (0.9, 0.7, 0.5, 1), "Anisotropy": 0.3})
    add_smoke(scene, os.path.join(str(out_dir), "cache"), pv, frames=6)
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (2, -1, 4))
    scenes.look_at(sun, (0, 0, 0))
    scenes.add_camera(scene, (0, -6, 2.0), (0, 0, 1.2), lens=40.0)
    # How much the smoke darkens its window against the same view without it (the test's power).
    scenes.volume_at_cycles_brightness(scene, out_dir, "smoke domain", "plume", (40, 30), samples=int(os.environ.get("SMOKE_SPP", 256)),
                                       tol=0.02, volume_step_rate=0.25)


def fire_material():
    """Principled Volume reading Cycles' "color" and "temperature" of a domain, with blackbody."""
    return volume_material("Fire", "ShaderNodeVolumePrincipled", **{
        "Density": 6.0, "Color Attribute": "color", "Blackbody Intensity": 1.0, "Temperature": 1000.0})


def test_fire_domain_exports_its_colour_and_flame_temperature(empty_scene, out_dir):
    scenes.add_camera(empty_scene)
    add_smoke(empty_scene, os.path.join(str(out_dir), "cache"), fire_material(), flow_type='BOTH',
              smoke_color=(1.0, 0.3, 0.1))
    ex = export_current()
    g = ex.description["media"]["Domain [Fire]"]["grid"]
    ds = bpy.data.objects["Domain"].modifiers["Fluid"].domain_settings
    assert g["smoke_color_grids"] == ["color_r", "color_g", "color_b", "density"], g
    assert g["temperature_grid"] == "flame" and g["density_grid"] == "density", g
    assert g["flame_temperature"] == [ds.flame_ignition, ds.flame_max_temp], g
    assert g["blackbody_intensity"] == 1.0, g
    assert not any(line.startswith("fluid domain attribute not rendered") for line in ex.warnings.lines())
    assert ex.build(native.get()) is not None


def test_smoke_without_fire_has_no_blackbody_light(empty_scene, out_dir):
    """Cycles' temperature of a domain without fire is 0: blackbody emission is nothing (no flame
    grid, or one without active voxels, whose voxels map to 0)."""
    scenes.add_camera(empty_scene)
    add_smoke(empty_scene, os.path.join(str(out_dir), "cache"), fire_material())
    g = export_current().description["media"]["Domain [Fire]"]["grid"]
    if "temperature_grid" in g:
        flame = {x["name"]: x for x in native.get().vdb_grids(g["file"])}["flame"]
        assert np.prod(flame["size"]) == 0, flame
    else:
        assert g["blackbody_intensity"] == 0.0, g


def test_fire_domain_at_cycles_brightness(empty_scene, out_dir):
    """A baked fire and coloured smoke plume (flow Fire + Smoke, red smoke; Principled Volume over
    Cycles' "color", "density" and "temperature" with Blackbody Intensity 1) over a floor under a
    dim World: the image mean and the plume's window within 2 % of Cycles' (the fire's own light
    dominates the image)."""
    scene = empty_scene
    scenes.set_world(scene, (0.5, 0.55, 0.6), 0.1)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    add_smoke(scene, os.path.join(str(out_dir), "cache"), fire_material(), frames=6, flow_type='BOTH',
              smoke_color=(1.0, 0.3, 0.1))
    scenes.add_camera(scene, (0, -6, 2.0), (0, 0, 1.2), lens=40.0)
    scenes.volume_at_cycles_brightness(scene, out_dir, "fire domain", "plume", (40, 30), samples=int(os.environ.get("SMOKE_SPP", 256)),
                                       tol=0.02, volume_step_rate=0.25)
