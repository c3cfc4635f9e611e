"""Export of a scene built here: meshes with modifiers, instances, every light type, a camera
with depth of field; checked against the counts, transforms and values expected."""
import json
import math

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import export, native


def export_current():
    return export.export_scene(bpy.context.evaluated_depsgraph_get())


def test_meshes_modifiers_and_instances(empty_scene):
    mat = scenes.diffuse_material("White")
    bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 0, 1))
    cube = bpy.context.active_object
    cube.data.materials.append(mat)
    cube.modifiers.new("subsurf", 'SUBSURF').levels = 1          # 6 faces -> 24 quads
    arr = cube.modifiers.new("array", 'ARRAY')                   # x2 -> 48 quads = 96 triangles
    arr.count = 2
    # two linked duplicates of one mesh: one record, two matrices
    bpy.ops.mesh.primitive_uv_sphere_add(segments=8, ring_count=4, location=(5, 0, 0))
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    dup = bpy.data.objects.new("Sphere.copy", sphere.data)
    empty_scene.collection.objects.link(dup)
    dup.location = (-5, 0, 0)
    dup.scale = (2, 2, 2)
    # a collection instance of the cube's collection-mate: a plane with a flat/smooth mix
    coll = bpy.data.collections.new("Instanced")
    plane = scenes.add_plane(empty_scene, "InstPlane", 1.0, mat)
    empty_scene.collection.objects.unlink(plane)
    coll.objects.link(plane)
    inst = bpy.data.objects.new("Instancer", None)
    inst.instance_type = 'COLLECTION'
    inst.instance_collection = coll
    inst.location = (0, 7, 0)
    empty_scene.collection.objects.link(inst)
    scenes.add_camera(empty_scene)

    ex = export_current()
    by_name = {m.name: m for m in ex.meshes}
    assert by_name["Cube"].triangle_count == 96
    assert by_name["Cube"].normals is None                      # flat cube: no normals
    sph = by_name["Sphere"]
    assert sph.triangle_count == 8 * 2 + 8 * 2 * 2              # 2 fans + 2 quad rings
    assert len(sph.matrices) == 2 and sph.normals is not None   # shared, smooth
    np.testing.assert_allclose(sph.matrices[1][:3, 3], (-5, 0, 0), atol=1e-6)
    np.testing.assert_allclose(np.diag(sph.matrices[1])[:3], (2, 2, 2), atol=1e-6)
    ip = by_name["InstPlane"]
    np.testing.assert_allclose(ip.matrices[0][:3, 3], (0, 7, 0), atol=1e-6)
    assert sph.positions.dtype == np.float32 and sph.indices.dtype == np.uint32
    scene = ex.build(native.get())
    assert scene.triangle_count == 96 + 2 * 48 + 2
    assert "White" in scene.material_names


def test_every_light_type_and_camera(empty_scene):
    scenes.add_plane(empty_scene, "Floor", 10.0, scenes.diffuse_material("Floor"))
    cam = scenes.add_camera(empty_scene, (0, -5, 2), (0, 0, 0), lens=35.0)
    cam.data.sensor_fit = 'HORIZONTAL'
    cam.data.sensor_width = 36.0
    cam.data.dof.use_dof = True
    cam.data.dof.aperture_fstop = 2.8
    cam.data.dof.focus_distance = 4.0
    cam.data.clip_start, cam.data.clip_end = 0.25, 80.0
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 200, 100
    empty_scene.render.resolution_percentage = 50
    lights = {}
    for case in scenes.LIGHT_CASES:
        lights[case] = scenes.add_light(empty_scene, case, *scenes.LIGHT_CASES[case], (1, 2, 3))
    lights["area_square"].scale = (2, 1, 1)  # area scales with the object, as in Cycles
    scenes.set_world(empty_scene, (0.1, 0.2, 0.3), 2.0)

    ex = export_current()
    d = ex.description
    by_name = {l["name"]: l for l in d["lights"]}
    assert by_name["point"]["type"] == "point" and by_name["point"]["power"] == 400.0
    assert by_name["point"]["position"] == pytest.approx([1, 2, 3])
    assert by_name["spot"]["spot_size"] == pytest.approx(70.0)
    assert by_name["spot"]["spot_blend"] == pytest.approx(0.3)
    assert by_name["spot"]["direction"] == pytest.approx([0, 0, -1])
    assert by_name["sun"]["strength"] == 2.0 and by_name["sun"]["direction"] == pytest.approx([0, 0, -1])
    mats = d["materials"]
    # area radiance = P / (4 A): square 1 m scaled x2 -> A = 2
    assert mats["__light_area_square"]["strength"] == pytest.approx(300 / (4 * 2.0))
    assert mats["__light_area_rectangle"]["strength"] == pytest.approx(300 / (4 * 0.75))
    assert mats["__light_area_disk"]["strength"] == pytest.approx(300 / (4 * math.pi / 4))
    assert mats["__light_area_ellipse"]["strength"] == pytest.approx(300 / (4 * math.pi * 1.2 * 0.6 / 4))
    areas = {m.name: m for m in ex.meshes if m.name.startswith("area")}
    assert areas["area_square"].triangle_count == 2 and areas["area_disk"].triangle_count == 64
    c = d["camera"]
    assert (c["width"], c["height"]) == (100, 50)
    assert c["sensor_fit"] == "horizontal"
    assert c["fov"] == pytest.approx(math.degrees(2 * math.atan(18 / 35)))
    assert c["aperture_radius"] == pytest.approx(0.035 / (2 * 2.8))
    assert c["focus_distance"] == pytest.approx(4.0)
    assert (c["clip_start"], c["clip_end"]) == pytest.approx((0.25, 80.0))  # Cycles clips camera rays
    assert c["matrix"][3] == pytest.approx(0) and c["matrix"][7] == pytest.approx(-5)
    assert d["environment"] == {"color": pytest.approx([0.1, 0.2, 0.3]), "strength": 2.0}
    scene = ex.build(native.get())
    assert scene.light_count == 3 + 2 + 64 + 64 + 2 + 1  # delta lights, area triangles, environment
    assert (scene.camera()["clip_start"], scene.camera()["clip_end"]) == pytest.approx((0.25, 80.0))


def test_the_rendered_viewport_clips_as_cycles_viewport(empty_scene):
    """The rendered viewport's camera (viewport.view_camera) takes Clip Start / End as Cycles'
    viewport does (blender/camera.cpp blender_camera_from_view): through the scene camera its
    own, as F12; in a perspective view the view's (View > Clip Start / End); in an orthographic
    view the view's far clip either side of the view plane (from the origin moved back by
    clip_end / 2: 0 to clip_end)."""
    from types import SimpleNamespace

    import mathutils
    from gradphoton import viewport

    cam = scenes.add_camera(empty_scene, (0, -5, 2), (0, 0, 0), lens=35.0)
    cam.data.clip_start, cam.data.clip_end = 0.25, 80.0
    bpy.context.view_layer.update()  # the camera's matrix_world
    space = SimpleNamespace(clip_start=0.5, clip_end=40.0, use_render_border=False)
    persp = mathutils.Matrix(((2.0, 0, 0, 0), (0, 2.0, 0, 0), (0, 0, -1.0, -0.1), (0, 0, -1.0, 0)))
    ortho = mathutils.Matrix(((0.2, 0, 0, 0), (0, 0.2, 0, 0), (0, 0, -0.05, 0), (0, 0, 0, 1.0)))

    def view(kind, window):
        rv3d = SimpleNamespace(view_matrix=cam.matrix_world.inverted(), window_matrix=window,
                               is_perspective=kind != 'ORTHO', view_perspective=kind)
        return viewport.view_camera(SimpleNamespace(region_data=rv3d, space_data=space), empty_scene, 64, 48)

    through_camera = view('CAMERA', persp)
    assert (through_camera["clip_start"], through_camera["clip_end"]) == pytest.approx((0.25, 80.0))
    free = view('PERSP', persp)
    assert (free["clip_start"], free["clip_end"]) == pytest.approx((0.5, 40.0))
    flat = view('ORTHO', ortho)
    assert "clip_start" not in flat and flat["clip_end"] == pytest.approx(40.0)
    # The origin moved back by 20 along the view's +Z (the camera at (0, -5, 2) looking at the origin).
    back = cam.matrix_world.col[2].xyz.normalized() * 20.0
    assert [flat["matrix"][3], flat["matrix"][7], flat["matrix"][11]] == pytest.approx(list(cam.location + back), abs=1e-4)
    # Each is a camera the core takes (Camera::check), with these clip planes.
    scene = export_current().build(native.get())
    for d in (through_camera, free, flat):
        scene.set_camera(json.dumps(d))
        assert scene.camera()["clip_start"] == pytest.approx(d.get("clip_start", 0.0))
        assert scene.camera()["clip_end"] == pytest.approx(d["clip_end"])


def test_materials_map_onto_the_closed_set(empty_scene):
    m = bpy.data.materials.new("Glass")
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Transmission"].default_value = 1.0
    p.inputs["Roughness"].default_value = 0.3
    p.inputs["IOR"].default_value = 1.6
    m.gradphoton.dispersion = 'ABBE'
    m.gradphoton.abbe = 40.0
    gold = bpy.data.materials.new("Gold")
    gold.use_nodes = True
    g = gold.node_tree.nodes["Principled BSDF"]
    g.inputs["Metallic"].default_value = 1.0
    g.inputs["Roughness"].default_value = 0.5
    w = export.Warnings()
    table = {}
    me = export.material.MaterialExporter(table, w)
    me.name_for(m)
    me.name_for(gold)
    assert table["Glass"] == {"type": "dielectric", "color": pytest.approx([0.8, 0.8, 0.8]),
                              "roughness": pytest.approx(0.09), "ior": pytest.approx(1.6), "abbe": 40.0,
                              "fresnel": "normal",  # Principled's GGX glass: Cycles 3.4's split
                              "specular_tint": 0.0}  # its reflection white (svm/closure.h)
    assert table["Gold"]["type"] == "conductor" and table["Gold"]["roughness"] == pytest.approx(0.25)
    assert not w


def test_export_operator_writes_a_scene_the_cli_loads(empty_scene, out_dir):
    scenes.brightness_scene(empty_scene, "area_disk")
    bpy.ops.mesh.primitive_monkey_add()
    path = str(out_dir / "scene.json")
    assert bpy.ops.gradphoton.export_scene(filepath=path) == {'FINISHED'}
    direct = export_current().build(native.get())
    loaded = native.get().load_scene(path)
    assert loaded.triangle_count == direct.triangle_count == 2 + 64 + 968
    assert loaded.light_count == direct.light_count


def test_ray_visibility_as_cycles(empty_scene):
    """Light objects are pass-through emitters that cast no shadow, shown to the camera only when
    their Visibility > Camera is on (off by default in Blender 3.4); a mesh object's Camera and
    Shadow switches become flags of a variant of its material, and so do its Diffuse, Glossy and
    Transmission switches (on lights too), honoured where the method says so (method_info): a
    warning naming the method and what it ignores otherwise. The World's Ray Visibility becomes the
    same keys on the environment."""
    scenes.cornell_lit(empty_scene, "area")
    lamp = bpy.data.objects["area"]
    assert not lamp.visible_camera  # Blender 3.4's default for a new light object
    floor, back = bpy.data.objects["Floor"], bpy.data.objects["Back"]
    floor.visible_camera = False
    back.visible_shadow = False
    back.visible_glossy = False
    lamp.visible_diffuse = False
    ex = export_current()
    mats = ex.description["materials"]
    m = mats["__light_area"]
    assert (m["type"], m["ior"], m["visible_to_camera"], m["casts_shadow"]) == ("dielectric", 1.0, False, False)
    assert m["visible_to_diffuse"] is False and "visible_to_glossy" not in m
    names = {r.name: r.materials for r in ex.meshes}
    assert mats[names["Floor"][0]] == dict(mats["White"], visible_to_camera=False)
    assert mats[names["Back"][0]] == dict(mats["White"], casts_shadow=False, visible_to_glossy=False)
    assert names["Ceiling"] == ["White"]
    assert not any("ray visibility" in line for line in ex.warnings.lines()), ex.warnings.lines()  # pt honours them
    for method in ('sppm', 'msppm', 'gpt', 'gpm', 'spt-hero', 'sgpt'):  # both kinds honoured, as pt
        empty_scene.gradphoton.method = method
        assert not any("ray visibility" in line for line in export_current().warnings.lines()), method
    empty_scene.gradphoton.method = 'pt'
    world_vis = empty_scene.world.cycles_visibility
    world_vis.camera = False
    world_vis.glossy = False
    env = export_current().description["environment"]  # the new world's grey colour
    assert env["visible_to_camera"] is False and env["visible_to_glossy"] is False and "visible_to_diffuse" not in env
    world_vis.camera = world_vis.glossy = True
    lamp.visible_camera = True
    assert export_current().description["materials"]["__light_area"]["visible_to_camera"] is True
    ex.build(native.get())  # the flags are scene-format keys the core reads


def test_skipped_features_are_counted_warnings(empty_scene):
    """Hair is not rendered: one warning naming what it skips. A material's Volume output is
    exported as a medium (test_volumes.py), motion blur sampled over the shutter
    (test_motion_blur.py): neither is skipped."""
    scenes.cornell_lit(empty_scene, "area")
    empty_scene.render.use_motion_blur = True
    floor = bpy.data.objects["Floor"]
    ps = floor.modifiers.new("hair", 'PARTICLE_SYSTEM').particle_system
    ps.settings.type = 'HAIR'
    vol = scenes.diffuse_material("Smoke")
    nt = vol.node_tree
    nt.links.new(nt.nodes.new("ShaderNodeVolumePrincipled").outputs[0], nt.nodes["Material Output"].inputs["Volume"])
    bpy.data.objects["Back"].data.materials[0] = vol
    lines = export_current().warnings.lines()
    assert not any(line.startswith("motion blur not rendered") for line in lines), lines
    assert any(line.startswith("hair curves not rendered: Floor") for line in lines), lines
    assert not any(line.startswith("volumes not rendered") for line in lines), lines  # (Volume objects render)
