"""Bad scenes in real Blender (docs/reliability.md, "Blender"): empty meshes, NaN and zero-scale
transforms, missing images, lights of zero size, a camera inside glass, non-ASCII names. Each
render (F12's operator, in this Blender) ends with the image or with a report naming what is
wrong, never a Python traceback or a crash; what renders is finite."""
import math

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import session


def lit_scene(scene):
    """A floor under a sun, seen by a camera: every bad thing below is added to it."""
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor"))
    la = bpy.data.lights.new("Sun", 'SUN')
    la.energy = 3.0
    ob = bpy.data.objects.new("Sun", la)
    scene.collection.objects.link(ob)
    scenes.add_camera(scene, (0, -6, 3), (0, 0, 0.8))


def render(scene, capfd):
    """F12 in this Blender: (reports, combined pixels or None, captured console text)."""
    session.REPORTS.clear()
    try:
        bpy.ops.render.render()
    except RuntimeError as e:  # an ERROR report reaches the operator's caller as RuntimeError
        assert str(e).startswith("Error: gradphoton"), e
    out, err = capfd.readouterr()
    console = out + err
    assert "Traceback" not in console, console
    pixels = None
    img = bpy.data.images.get("Render Result")
    if img is not None:
        path = bpy.app.tempdir + "bad_scene.exr"
        scene.render.image_settings.file_format = 'OPEN_EXR'
        try:
            img.save_render(path)
            from gradphoton import native
            pixels = native.get().read_exr(path).get("combined")
        except RuntimeError:
            pixels = None
    return list(session.REPORTS), pixels, console


def errors(reports):
    return [m for level, m in reports if level == 'ERROR']


def assert_rendered_finite(reports, pixels):
    assert not errors(reports), reports
    assert pixels is not None and np.isfinite(pixels).all()


def test_empty_meshes_render_without_them(empty_scene, capfd):
    lit_scene(empty_scene)
    scenes.add_mesh_object(empty_scene, "Empty mesh", [], [])
    scenes.add_mesh_object(empty_scene, "Loose verts", [(0, 0, 0), (1, 0, 0)], [])
    scenes.add_mesh_object(empty_scene, "Flat face", [(0, 0, 1), (1, 0, 1), (2, 0, 1)], [(0, 1, 2)])
    reports, pixels, _ = render(empty_scene, capfd)
    assert_rendered_finite(reports, pixels)


def test_nan_transform_is_a_report_naming_the_object(empty_scene, capfd):
    lit_scene(empty_scene)
    ob = scenes.add_mesh_object(empty_scene, "Broken", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)])
    ob.location = (math.nan, 0, 0)
    reports, _, _ = render(empty_scene, capfd)
    assert any("Broken" in m and "not finite" in m for m in errors(reports)), reports


def test_zero_scale_object_is_left_out_with_a_warning(empty_scene, capfd):
    lit_scene(empty_scene)
    ob = scenes.add_mesh_object(empty_scene, "Squashed", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)])
    ob.scale = (0, 0, 0)
    reports, pixels, _ = render(empty_scene, capfd)
    assert_rendered_finite(reports, pixels)
    assert any("Squashed" in m for level, m in reports if level == 'WARNING'), reports


def test_missing_image_is_a_warning_and_renders(empty_scene, capfd):
    lit_scene(empty_scene)
    m = bpy.data.materials["Floor"]
    tex = m.node_tree.nodes.new("ShaderNodeTexImage")
    img = bpy.data.images.new("missing texture", 4, 4)
    img.source = 'FILE'
    img.filepath = "/nonexistent/missing texture.png"
    tex.image = img
    m.node_tree.links.new(tex.outputs["Color"], m.node_tree.nodes["Diffuse BSDF"].inputs["Color"])
    reports, pixels, _ = render(empty_scene, capfd)
    assert_rendered_finite(reports, pixels)
    assert any(level == 'WARNING' for level, _ in reports), reports


@pytest.mark.parametrize("kind", ['AREA', 'POINT', 'SPOT'])
def test_lights_of_zero_size_render(empty_scene, capfd, kind):
    lit_scene(empty_scene)
    la = bpy.data.lights.new("Tiny", kind)
    la.energy = 100.0
    if kind == 'AREA':
        la.size = 0.0
        la.size_y = 0.0
    else:
        la.shadow_soft_size = 0.0
    if kind == 'SPOT':
        la.spot_size = 0.0
    ob = bpy.data.objects.new("Tiny", la)
    empty_scene.collection.objects.link(ob)
    ob.location = (0, 0, 2)
    reports, pixels, _ = render(empty_scene, capfd)
    assert_rendered_finite(reports, pixels)


def test_camera_inside_glass_renders(empty_scene, capfd):
    lit_scene(empty_scene)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=20, location=(0, 0, 0))
    bpy.context.active_object.data.materials.append(scenes.glass_material("Glass"))
    reports, pixels, _ = render(empty_scene, capfd)
    assert_rendered_finite(reports, pixels)


def test_non_ascii_names_render_and_reach_reports(empty_scene, capfd):
    lit_scene(empty_scene)
    ob = scenes.add_mesh_object(empty_scene, "Würfel ✓ 立方体", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)],
                                scenes.diffuse_material("Матеріал"))
    bpy.data.objects["Sun"].name = "Sonne ☀"
    reports, pixels, _ = render(empty_scene, capfd)
    assert_rendered_finite(reports, pixels)
    ob.location = (math.nan, 0, 0)  # the error names the object, non-ASCII and all
    reports, _, _ = render(empty_scene, capfd)
    assert any("Würfel ✓ 立方体" in m for m in errors(reports)), reports


def test_scene_without_camera_is_a_report(empty_scene, capfd):
    lit_scene(empty_scene)
    bpy.data.objects.remove(bpy.data.objects["Camera"])
    empty_scene.camera = None
    session.REPORTS.clear()
    try:
        bpy.ops.render.render()
    except RuntimeError as e:  # Blender itself refuses: "No camera found in scene"
        assert "camera" in str(e).lower()
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err
