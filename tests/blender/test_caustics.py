"""Light Paths > Caustics (Filter Glossy, Reflective and Refractive Caustics): the exporter writes
Cycles' own settings (scene.cycles.blur_glossy, caustics_reflective, caustics_refractive) as the
scene's filter_glossy and caustics_* (docs/scene-format.md), which pt, spt and spt-hero honour;
and Blender's Sharp distribution as "sharp" (Cycles 3.4's singular closure, which Filter Glossy
leaves sharp where it blurs GGX at roughness 0)."""
import bpy

import scenes
from gradphoton.export import export_scene


def _scene(scene):
    scenes.set_world(scene)
    scenes.add_plane(scene, "Floor", 4.0, scenes.diffuse_material("Floor", (0.8, 0.8, 0.8)))
    sphere_mat = scenes.glass_material("Glass")  # Glass BSDF, Sharp
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0, 0, 1))
    bpy.context.active_object.data.materials.append(sphere_mat)
    scenes.add_camera(scene, (0, -4, 2), (0, 0, 0.5))


def test_caustics_settings_exported_as_cycles_reads_them(empty_scene):
    _scene(empty_scene)
    c = empty_scene.cycles
    assert (c.blur_glossy, c.caustics_reflective, c.caustics_refractive) == (1.0, True, True)  # Cycles' defaults
    for blur, reflective, refractive in ((1.0, True, True), (0.0, False, True), (2.5, True, False), (0.5, False, False)):
        c.blur_glossy, c.caustics_reflective, c.caustics_refractive = blur, reflective, refractive
        d = export_scene(bpy.context.evaluated_depsgraph_get()).description
        assert d["filter_glossy"] == blur
        assert d["caustics_reflective"] is reflective
        assert d["caustics_refractive"] is refractive


def test_sharp_glass_exported_as_sharp(empty_scene):
    _scene(empty_scene)
    d = export_scene(bpy.context.evaluated_depsgraph_get()).description
    glass = [m for m in d["materials"].values() if m.get("type") == "dielectric"]
    assert glass and all(m.get("distribution") == "sharp" and m.get("roughness") == 0.0 for m in glass), glass
