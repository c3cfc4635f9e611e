"""Motion blur export as Cycles 3.4 samples it (export/motion.py): the times each Position and
Steps give, per-object switches (and an instancer's), deformation as per-step positions, topology
changes, instances, the camera, the warnings, static scenes exported as without motion blur,
the viewport without blur, and the panels."""
import json
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import export, native, sync, ui
from gradphoton.export import motion
from test_method_params import _Layout


def export_final():
    """The scene as a final render exports it: sampled over the shutter (scene.frame_set)."""
    bpy.context.view_layer.update()  # settings changed since the last evaluation
    dg = bpy.context.evaluated_depsgraph_get()
    return export.export_scene(dg, frame_set=export.scene_frame_set(dg))


def linear(ob, path, frames_values):
    """Keys `path` at each (frame, value) with linear interpolation."""
    for frame, value in frames_values:
        setattr(ob, path, value)
        ob.keyframe_insert(path, frame=frame)
    for fc in ob.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = 'LINEAR'


def sliding_cube(scene, name="Cube", speed=1.0):
    """A cube at x = speed * (frame - 1): one unit a frame at speed 1."""
    bpy.ops.mesh.primitive_cube_add(size=1)
    cube = bpy.context.active_object
    cube.name = name
    cube.data.materials.append(scenes.diffuse_material(name + "Mat"))
    linear(cube, "location", [(1, (0, 0, 0)), (11, (10 * speed, 0, 0))])
    return cube


def record(ex, name):
    return next(m for m in ex.meshes if name in m.instance_names)


@pytest.fixture
def blur_scene(empty_scene):
    scenes.add_camera(empty_scene)
    empty_scene.render.use_motion_blur = True
    empty_scene.render.motion_blur_shutter = 0.5
    empty_scene.cycles.motion_blur_position = 'CENTER'
    empty_scene.cycles.rolling_shutter_type = 'NONE'
    empty_scene.render.motion_blur_shutter_curve.reset_view()
    empty_scene.view_layers[0].use_motion_blur = True
    empty_scene.frame_set(5)
    yield empty_scene
    empty_scene.render.use_motion_blur = False
    empty_scene.frame_set(1)


# ---- times ----

# Cube at x = frame - 1, frame 5, shutter 0.5 (Cycles' sync_motion: frame + offset + rel * s/2).
POSITION_X = {'CENTER': [3.75, 4.0, 4.25], 'START': [4.0, 4.25, 4.5], 'END': [3.5, 3.75, 4.0]}


@pytest.mark.parametrize("position", list(POSITION_X))
def test_shutter_position_sets_the_times(blur_scene, position):
    sliding_cube(blur_scene)
    blur_scene.cycles.motion_blur_position = position
    ex = export_final()
    rec = record(ex, "Cube")
    np.testing.assert_allclose(rec.matrices[0][0, 3], 4.0, atol=1e-6)  # the frame's own
    assert rec.motion.shape == (1, 3, 4, 4)
    np.testing.assert_allclose(rec.motion[0, :, 0, 3], POSITION_X[position], atol=1e-5)
    assert ex.moving == ["Cube"]
    assert (blur_scene.frame_current, blur_scene.frame_subframe) == (5, 0.0)  # restored


@pytest.mark.parametrize("steps,samples", [(1, 3), (2, 5), (3, 9)])
def test_steps_give_cycles_sample_counts(blur_scene, steps, samples):
    cube = sliding_cube(blur_scene)
    cube.cycles.motion_steps = steps
    blur_scene.render.motion_blur_shutter = 1.0
    m = record(export_final(), "Cube").motion[0]
    assert m.shape == (samples, 4, 4)
    np.testing.assert_allclose(m[:, 0, 3], np.linspace(3.5, 4.5, samples), atol=1e-5)


def test_rotation_is_sampled_not_interpolated(blur_scene):
    """A quarter turn a frame: each step's matrix is Blender's own at that time (the core
    interpolates between them as Cycles does)."""
    bpy.ops.mesh.primitive_cube_add(size=1)
    cube = bpy.context.active_object
    linear(cube, "rotation_euler", [(1, (0, 0, 0)), (2, (0, 0, np.pi / 2))])
    blur_scene.frame_set(1)
    blur_scene.render.motion_blur_shutter = 1.0
    blur_scene.cycles.motion_blur_position = 'START'
    cube.cycles.motion_steps = 2
    m = record(export_final(), "Cube").motion[0]
    angles = np.arctan2(m[:, 1, 0], m[:, 0, 0])
    np.testing.assert_allclose(angles, np.linspace(0, np.pi / 2, 5), atol=1e-5)
    np.testing.assert_allclose(np.linalg.det(m[:, :3, :3]), 1.0, atol=1e-5)


# ---- switches ----

def test_static_scene_exports_exactly_as_without_motion_blur(blur_scene):
    bpy.ops.mesh.primitive_monkey_add()
    sliding_cube(blur_scene).animation_data_clear()  # keyed, then static
    with_blur = export_final()
    assert with_blur.moving == [] and all(m.motion is None and m.motion_positions is None for m in with_blur.meshes)
    blur_scene.render.use_motion_blur = False
    without = export_final()
    assert json.dumps(with_blur.to_json()) == json.dumps(without.to_json())


def test_motion_blur_off_does_not_evaluate_other_times(blur_scene):
    sliding_cube(blur_scene)
    calls = []
    dg = bpy.context.evaluated_depsgraph_get()
    for use, layer in ((False, True), (True, False)):
        blur_scene.render.use_motion_blur = use
        blur_scene.view_layers[0].use_motion_blur = layer
        ex = export.export_scene(dg, frame_set=lambda f, s: calls.append((f, s)))
        assert ex.moving == [] and record(ex, "Cube").motion is None
    assert calls == []


def test_viewport_export_has_no_motion(blur_scene):
    """No frame_set (the rendered viewport, sync.py): nothing blurs, as in Cycles' viewport."""
    sliding_cube(blur_scene)
    plan = sync.SceneSync().sync(bpy.context.evaluated_depsgraph_get(), first=True)
    assert plan.rebuild.moving == [] and all(m.motion is None for m in plan.rebuild.meshes)


def test_object_switch_turns_motion_off(blur_scene):
    cube = sliding_cube(blur_scene)
    cube.cycles.use_motion_blur = False
    ex = export_final()
    assert record(ex, "Cube").motion is None and ex.moving == []


def test_persistent_data_rebuilds_frames_with_motion(blur_scene):
    sliding_cube(blur_scene)
    s = sync.SceneSync()
    dg = bpy.context.evaluated_depsgraph_get()
    fs = export.scene_frame_set(dg)
    assert s.sync(dg, first=True, frame_set=fs).kinds() == ["rebuild"]
    blur_scene.frame_set(6)
    plan = s.sync(dg, frame_set=fs)
    assert plan.kinds() == ["rebuild"] and plan.reason == "motion blur"
    np.testing.assert_allclose(plan.rebuild.meshes[0].motion[0, :, 0, 3], [4.75, 5.0, 5.25], atol=1e-5)


# ---- deformation ----

def wavy_plane(scene, name="Wavy"):
    """A 4x4-vertex grid whose shape key lifts every vertex by the frame number / 10."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=4, size=2)
    ob = bpy.context.active_object
    ob.name = name
    ob.shape_key_add(name="Basis")
    key = ob.shape_key_add(name="Up")
    for v in key.data:
        v.co.z += 1.0
    kb = ob.data.shape_keys.key_blocks["Up"]
    kb.slider_max = 10.0
    for frame in (0, 10):
        kb.value = frame / 10.0
        kb.keyframe_insert("value", frame=frame)
    for fc in ob.data.shape_keys.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = 'LINEAR'
    return ob


def test_deformation_exports_positions_per_step(blur_scene):
    ob = wavy_plane(blur_scene)
    ex = export_final()
    rec = record(ex, "Wavy")
    assert rec.motion is None  # it does not move as a whole
    assert rec.motion_positions.shape == (3,) + rec.positions.shape and rec.motion_positions.dtype == np.float32
    np.testing.assert_allclose(rec.motion_positions[:, :, 2].mean(axis=1), [0.475, 0.5, 0.525], atol=1e-5)
    np.testing.assert_array_equal(rec.motion_positions[1], rec.positions)  # Center: step 1 is the frame
    assert ex.moving == ["Wavy"]
    ob.cycles.use_deform_motion = False
    assert record(export_final(), "Wavy").motion_positions is None


def test_topology_change_is_a_warning_without_deformation_blur(blur_scene):
    """The shape-keyed grid (so that it deforms, by Cycles' test) under a Build modifier that
    adds faces every frame: no deformation blur, one warning naming it; it still moves as a whole."""
    ob = wavy_plane(blur_scene, "Growing")
    build = ob.modifiers.new("build", 'BUILD')
    build.frame_start, build.frame_duration = 4, 2  # 8 faces more a frame
    linear(ob, "location", [(1, (0, 0, 0)), (11, (10, 0, 0))])
    ex = export_final()
    rec = record(ex, "Growing")
    assert rec.motion_positions is None and rec.motion is not None
    assert any(line.startswith("topology changes during the shutter (no deformation blur): Growing")
               for line in ex.warnings.lines()), ex.warnings.lines()


# ---- instances ----

def test_collection_instances_move_with_their_instancer(blur_scene):
    coll = bpy.data.collections.new("Props")
    cube = sliding_cube(blur_scene, "Prop")
    cube.animation_data_clear()
    cube.location = (0, 0, 0)
    blur_scene.collection.objects.unlink(cube)
    coll.objects.link(cube)
    insts = []
    for i in range(2):
        e = bpy.data.objects.new(f"Instancer{i}", None)
        e.instance_type, e.instance_collection = 'COLLECTION', coll
        blur_scene.collection.objects.link(e)
        linear(e, "location", [(1, (0, 3 * i, 0)), (11, (10, 3 * i, 0))])
        insts.append(e)
    insts[1].cycles.motion_steps = 2  # 5 samples: a record of its own (one S per native mesh)
    ex = export_final()
    recs = [m for m in ex.meshes if m.name == "Prop"]
    by_steps = {m.motion.shape[1]: m for m in recs}
    assert sorted(by_steps) == [3, 5]
    np.testing.assert_allclose(by_steps[3].motion[0, :, 0, 3], [3.75, 4.0, 4.25], atol=1e-5)
    np.testing.assert_allclose(by_steps[5].motion[0, :, 1, 3], [3.0] * 5, atol=1e-5)
    insts[0].cycles.use_motion_blur = False  # the instancer's switch turns its instances off
    recs = [m for m in export_final().meshes if m.name == "Prop"]
    assert len(recs) == 1 and recs[0].motion.shape[:2] == (2, 5)  # the static one as 5 equal matrices
    for k, steps in enumerate(recs[0].motion):
        moves = not (steps == steps[0]).all()
        assert moves == (recs[0].matrices[k][1, 3] == pytest.approx(3.0)), k


def test_geometry_nodes_instances_move(blur_scene):
    """Instance on Points of a moving grid's vertices: each instance is sampled by its
    persistent id."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=2, y_subdivisions=2, size=2)
    grid = bpy.context.active_object
    grid.name = "Scatter"
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.1)
    ball = bpy.context.active_object
    ball.name = "Ball"
    ball.hide_render = True
    mod = grid.modifiers.new("nodes", 'NODES')
    nt = bpy.data.node_groups.new("Scatter", 'GeometryNodeTree')
    nt.inputs.new('NodeSocketGeometry', "Geometry")
    nt.outputs.new('NodeSocketGeometry', "Geometry")
    gin, gout = nt.nodes.new("NodeGroupInput"), nt.nodes.new("NodeGroupOutput")
    iop, info = nt.nodes.new("GeometryNodeInstanceOnPoints"), nt.nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = ball
    nt.links.new(gin.outputs[0], iop.inputs["Points"])
    nt.links.new(info.outputs["Geometry"], iop.inputs["Instance"])
    nt.links.new(iop.outputs[0], gout.inputs[0])
    mod.node_group = nt
    linear(grid, "location", [(1, (0, 0, 0)), (11, (0, 0, 10))])
    ex = export_final()
    moving = [(m, k) for m in ex.meshes if m.motion is not None for k in range(len(m.matrices))]
    assert len(moving) == len(grid.data.vertices) == 9, [(m.name, m.instance_names) for m in ex.meshes]
    for m, k in moving:
        np.testing.assert_allclose(m.motion[k, :, 2, 3], [3.75, 4.0, 4.25], atol=1e-5)


def test_particle_instances_move_with_their_emitter(blur_scene):
    """Hair particles rendered as an object, on a moving emitter: every particle's instance is
    sampled (matched by its persistent id)."""
    bpy.ops.mesh.primitive_plane_add(size=2)
    emitter = bpy.context.active_object
    emitter.name = "Emitter"
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.05)
    grain = bpy.context.active_object
    grain.name = "Grain"
    grain.hide_render = True
    ps = emitter.modifiers.new("particles", 'PARTICLE_SYSTEM').particle_system
    ps.settings.type = 'HAIR'
    ps.settings.count = 6
    ps.settings.render_type = 'OBJECT'
    ps.settings.instance_object = grain
    ps.settings.use_advanced_hair = True
    linear(emitter, "location", [(1, (0, 0, 0)), (11, (0, 10, 0))])
    ex = export_final()
    grains = next(m for m in ex.meshes if m.name == "Grain")  # the 6 particles and Grain itself (a test
    moves = grains.motion[:, 2, 1, 3] - grains.motion[:, 0, 1, 3]  # depsgraph is the viewport's: shown)
    assert grains.motion.shape[1] == 3 and sorted(np.round(moves, 4).tolist()) == [0.0] + [0.5] * 6


# ---- camera ----

def test_camera_motion_with_its_own_switch(blur_scene):
    scenes.add_plane(blur_scene, "Floor", 10.0)
    cam = blur_scene.camera
    linear(cam, "location", [(1, (0, 0, 10)), (11, (10, 0, 10))])
    ex = export_final()
    m = np.array(ex.description["camera"]["motion"])
    assert m.shape == (3, 16)
    np.testing.assert_allclose(m[:, 3], [3.75, 4.0, 4.25], atol=1e-5)
    assert ex.description["camera"]["matrix"][3] == pytest.approx(4.0)
    assert "camera" in ex.moving
    cam.cycles.use_motion_blur = False
    assert "motion" not in export_final().description["camera"]


# ---- warnings ----

def test_a_zoom_during_the_shutter_is_one_warning_naming_the_camera(blur_scene):
    """Cycles blurs a focal-length change over the shutter; the core keeps the frame's lens, so
    the export says so once, naming the camera (and not when only the camera moves)."""
    cam = blur_scene.camera
    linear(cam, "location", [(1, (0, 0, 10)), (11, (10, 0, 10))])
    assert not any("lens" in l for l in export_final().warnings.lines())
    linear(cam.data, "lens", [(1, 50.0), (11, 30.0)])
    lines = [l for l in export_final().warnings.lines() if "lens" in l]
    assert len(lines) == 1 and cam.name in lines[0], lines


def test_shutter_curve_and_rolling_shutter_warn_naming_the_setting(blur_scene):
    sliding_cube(blur_scene)
    assert export_final().warnings.lines() == [] or not any("Shutter" in l for l in export_final().warnings.lines())
    curve = blur_scene.render.motion_blur_shutter_curve
    curve.curves[0].points[0].location = (0.0, 0.0)
    curve.update()
    blur_scene.cycles.rolling_shutter_type = 'TOP'
    lines = export_final().warnings.lines()
    assert any(l.startswith("motion blur Shutter Curve not rendered") for l in lines), lines
    assert any(l.startswith("motion blur Rolling Shutter not rendered") for l in lines), lines
    curve.curves[0].points[0].location = (0.0, 1.0)
    curve.update()


@pytest.mark.parametrize("kind,shape", [('POINT', None), ('SPOT', None), ('SUN', None), ('AREA', 'SQUARE')])
def test_moving_lamps_export_their_motion(blur_scene, kind, shape):
    """A lamp sliding along x and turning about y: its matrices at Cycles' times (frame 5, Shutter
    0.5, Steps 1: frames 4.75, 5, 5.25), no warning; the native scene places it mid-shutter at
    the frame's place, and a point/spot/sun light's dict drops its frame position/direction."""
    scenes.add_plane(blur_scene, "Floor", 10.0)
    lamp = scenes.add_light(blur_scene, "Lamp", kind, shape, 100.0, {}, (0, 0, 3))
    linear(lamp, "location", [(1, (0, 0, 3)), (11, (10, 0, 3))])
    linear(lamp, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 1.0, 0))])
    blur_scene.gradphoton.motion_blur_lights = True
    ex = export_final()
    blur_scene.gradphoton.motion_blur_lights = False
    assert not any("lights moving" in l for l in ex.warnings.lines()), ex.warnings.lines()
    assert "Lamp" in ex.moving
    if kind == 'AREA':
        ms = record(ex, "Lamp").motion[0]
    else:
        d = next(l for l in ex.description["lights"] if l["name"] == "Lamp")
        assert "position" not in d and "direction" not in d
        ms = np.array([np.reshape(m["matrix"], (4, 4)) for m in d["motion"]])
    assert ms.shape == (3, 4, 4)
    np.testing.assert_allclose(ms[:, 0, 3], [3.75, 4.0, 4.25], atol=1e-5)
    scene = ex.build(native.get())
    if kind != 'AREA':
        got = next(l for l in scene.lights() if l["name"] == "Lamp")
        np.testing.assert_allclose(got["position"], (4.0, 0.0, 3.0), atol=1e-4)
        # -Z turned by 0.4 rad about y at frame 5: (-sin 0.4, 0, -cos 0.4).
        np.testing.assert_allclose(got["direction"], (-np.sin(0.4), 0.0, -np.cos(0.4)), atol=1e-4)
    json.dumps(ex.to_json())  # the scene file carries it too


def test_moving_lamps_stay_at_the_frame_by_default_as_in_cycles(blur_scene):
    """Cycles 3.4 does not blur lights (moving_spot below: its blurred render equals its sharp
    one); without Blur Moving Lights neither do we: no motion, no warning, no other time read."""
    scenes.add_plane(blur_scene, "Floor", 10.0)
    lamp = scenes.add_light(blur_scene, "Lamp", 'SPOT', None, 100.0, {}, (0, 0, 3))
    linear(lamp, "location", [(1, (0, 0, 3)), (11, (10, 0, 3))])
    assert not blur_scene.gradphoton.motion_blur_lights
    ex = export_final()
    d = next(l for l in ex.description["lights"] if l["name"] == "Lamp")
    assert "motion" not in d and d["position"] == pytest.approx([4.0, 0.0, 3.0])
    assert ex.moving == [] and not ex.warnings.lines()


def test_a_still_lamp_exports_as_without_motion_blur(blur_scene):
    scenes.add_plane(blur_scene, "Floor", 10.0)
    scenes.add_light(blur_scene, "Lamp", 'SPOT', None, 100.0, {}, (0, 0, 3))
    blur_scene.gradphoton.motion_blur_lights = True
    ex = export_final()
    blur_scene.gradphoton.motion_blur_lights = False
    d = next(l for l in ex.description["lights"] if l["name"] == "Lamp")
    assert "motion" not in d and "position" in d and "direction" in d
    assert ex.moving == []


@pytest.mark.parametrize("method", native.methods())
def test_a_method_without_motion_blur_says_so_from_its_declaration(blur_scene, method):
    """The core's feature_report (the media warning's way): one line iff the method's declaration
    says it does not render motion blur; the exporter's old blanket warning is gone."""
    sliding_cube(blur_scene)
    blur_scene.gradphoton.method = method
    ex = export_final()
    assert not any(l.startswith("motion blur not rendered") for l in ex.warnings.lines())
    supported = native.method_description(method)["supports"]["motion_blur"]
    report = native.get().Session(ex.build(native.get()), method, {}).feature_report
    assert any("motion blur" in line for line in report) == (not supported), report


# ---- to_json ----

def test_to_json_writes_motion_and_deformation(blur_scene):
    sliding_cube(blur_scene)
    wavy_plane(blur_scene)
    bpy.ops.mesh.primitive_monkey_add(location=(0, 5, 0))
    d = export_final().to_json()
    objs = {o["name"]: o for o in d["objects"]}
    cube, wavy, monkey = objs["Cube"], objs["Wavy"], objs["Suzanne"]
    assert "transform" not in cube and len(cube["motion"]) == 3
    assert cube["motion"][2]["matrix"][3] == pytest.approx(4.25)
    assert "transform" in wavy and len(wavy["motion_positions"]) == 3
    assert len(wavy["motion_positions"][0]) == len(wavy["positions"]) * 3
    assert "motion" not in monkey and "motion_positions" not in monkey


# ---- panels ----

def _ctx(scene, ob=None, engine="GRADPHOTON"):
    return SimpleNamespace(engine=engine, scene=scene, object=ob)


def _draw(panel_cls, context):
    panel = SimpleNamespace(layout=_Layout())
    if hasattr(panel_cls, "draw_header"):
        panel_cls.draw_header(panel, context)
    panel_cls.draw(panel, context)
    return panel.layout.drawn


def test_motion_blur_panels_as_cycles(blur_scene):
    render_panel, obj_panel = ui.GRADPHOTON_RENDER_PT_motion_blur, ui.GRADPHOTON_OBJECT_PT_motion_blur
    assert render_panel.poll(_ctx(blur_scene)) and not render_panel.poll(_ctx(blur_scene, engine="CYCLES"))
    # Cycles' settings, and ours: Blur Moving Lights (Cycles does not blur lights).
    assert _draw(render_panel, _ctx(blur_scene)) == ["use_motion_blur", "motion_blur_position", "motion_blur_shutter",
                                                     "motion_blur_lights", "rolling_shutter_type",
                                                     "rolling_shutter_duration"]
    assert ui.GRADPHOTON_RENDER_PT_motion_blur_curve.bl_parent_id == "GRADPHOTON_RENDER_PT_motion_blur"
    cube = sliding_cube(blur_scene)
    empty = bpy.data.objects.new("Empty", None)
    assert obj_panel.poll(_ctx(blur_scene, cube)) and obj_panel.poll(_ctx(blur_scene, blur_scene.camera))
    assert not obj_panel.poll(_ctx(blur_scene, empty))
    assert _draw(obj_panel, _ctx(blur_scene, cube)) == ["use_motion_blur", "motion_steps", "use_deform_motion"]
    assert _draw(obj_panel, _ctx(blur_scene, blur_scene.camera)) == ["use_motion_blur", "motion_steps"]


# ---- renders ----

def read_rgb(path):
    return native.get().read_exr(path)["combined"][..., :3].astype(np.float64)


def test_f12_render_of_a_static_scene_with_motion_blur_is_bit_for_bit(blur_scene, out_dir):
    """Motion blur on, nothing moving: the render goes through RenderEngine.frame_set (each
    shutter time evaluated, the frame restored) and the image is the one without motion blur."""
    scenes.add_plane(blur_scene, "Floor", 10.0, scenes.diffuse_material("Floor"))
    bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 1))
    scenes.add_light(blur_scene, "Sun", 'SUN', None, 3.0, {}, (0, 0, 5))
    blur_scene.gradphoton.passes = 2
    with_blur = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / "blur.exr")))
    assert (blur_scene.frame_current, blur_scene.frame_subframe) == (5, 0.0)
    blur_scene.render.use_motion_blur = False
    without = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / "still.exr")))
    assert with_blur.mean() > 0.01
    np.testing.assert_array_equal(with_blur, without)


# Against Cycles 3.4 (same .blend, Render > Motion Blur on, Shutter 0.5, Position Center): the
# image mean within 1 % and relMSE = mean((ours - cycles)^2 / (cycles^2 + 0.01)) below a bound
# about twice what was measured (docs/blender.md, "Motion blur"). Both engines sample the same
# Blender times (3 per object: Steps 1), and interpolate between them as Cycles does. The
# unblurred frame (Cycles) must be further from Cycles' blurred one than twice the bound, so
# that the test tells blur from no blur. gradphoton's path tracer is the noisier of the two at
# equal samples (relMSE 0.004 against its own 1024-pass image at 64 passes, Cycles' 0.0004), so
# it takes 512 passes to Cycles' 128.
MOTION_SIZE, CYCLES_SAMPLES, GRADPHOTON_PASSES = (48, 36), 128, 512
MOTION_MEAN = 0.01
MOTION_RELMSE = {"sliding_turning_cube": 0.0015, "falling_ball": 0.0015, "panning_camera": 0.0015,
                 "stretching_cube": 0.0015, "checker_slider": 0.0015, "moving_spot": 0.0125}


def _lit_floor(scene):
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    # A sharp sun and a black world: little noise beside the blur's own (soft shadows and a
    # lit world made gradphoton's and Cycles' noise alone as large as the blur's effect).
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (0, 0, 5))
    sun.rotation_euler = (0.6, 0.2, 0.3)


def sliding_turning_cube(scene):
    """A cube sliding one unit and turning 90 degrees a frame, seen from above: under a 0.5
    shutter it sweeps half a unit and 45 degrees."""
    _lit_floor(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 0.5))
    cube = bpy.context.active_object
    cube.data.materials.append(scenes.diffuse_material("Red", (0.8, 0.1, 0.1)))
    linear(cube, "location", [(1, (-2, 0, 0.5)), (5, (2, 0, 0.5))])
    linear(cube, "rotation_euler", [(1, (0, 0, 0)), (5, (0, 0, 2 * np.pi))])
    scenes.add_camera(scene, (0, 0, 8), (0, 0, 0))
    scene.frame_set(3)


def falling_ball(scene):
    """A ball falling past a wall as under gravity (Blender's Quadratic ease-in keys: z falls as
    t^2), seen at frame 6, where it falls about 1.1 m within the shutter."""
    _lit_floor(scene)
    scenes.add_plane(scene, "Wall", 20.0, scenes.diffuse_material("Wall", (0.3, 0.5, 0.7)), (0, 3, 0))
    bpy.data.objects["Wall"].rotation_euler = (np.pi / 2, 0, 0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, location=(0, 0, 8.4))
    ball = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    ball.data.materials.append(scenes.diffuse_material("Ball", (0.9, 0.8, 0.2)))
    ball.keyframe_insert("location", frame=1)
    ball.location = (0, 0, 0.4)
    ball.keyframe_insert("location", frame=7)
    for fc in ball.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation, k.easing = 'QUAD', 'EASE_IN'
    scenes.add_camera(scene, (0, -8, 2), (0, 0, 2))
    scene.frame_set(6)


def panning_camera(scene):
    """A still scene under a camera turning 10 degrees a frame (5 degrees within the shutter)."""
    _lit_floor(scene)
    for i, x in enumerate((-1.5, 0.0, 1.5)):
        bpy.ops.mesh.primitive_cube_add(size=0.8, location=(x, 2 * (i % 2), 0.4))
        bpy.context.active_object.data.materials.append(
            scenes.diffuse_material(f"Box{i}", ((0.8, 0.2, 0.2), (0.2, 0.8, 0.2), (0.2, 0.2, 0.8))[i]))
    cam = scenes.add_camera(scene, (0, -6, 2), (0, 0, 0.5))
    r0 = cam.rotation_euler.z
    linear(cam, "rotation_euler", [(1, (cam.rotation_euler.x, 0, r0 - 0.35)), (5, (cam.rotation_euler.x, 0, r0 + 0.35))])
    scene.frame_set(3)


def stretching_cube(scene):
    """Deformation: a cube whose shape key pulls its +x face out by two units a frame (the object
    does not move), seen from above."""
    _lit_floor(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(-1, 0, 0.5))
    cube = bpy.context.active_object
    cube.data.materials.append(scenes.diffuse_material("Red", (0.8, 0.1, 0.1)))
    cube.shape_key_add(name="Basis")
    key = cube.shape_key_add(name="Long")
    for v in key.data:
        if v.co.x > 0:
            v.co.x += 4.0
    kb = cube.data.shape_keys.key_blocks["Long"]
    for frame, value in ((1, 0.0), (3, 1.0)):
        kb.value = value
        kb.keyframe_insert("value", frame=frame)
    for fc in cube.data.shape_keys.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = 'LINEAR'
    scenes.add_camera(scene, (0, 0, 8), (0, 0, 0))
    scene.frame_set(2)


def moving_spot(scene):
    """A spot lamp sliding two units and turning 0.6 rad a frame over a grey floor (no sun), seen
    from above: its lit ellipse sweeps one unit and turns within the shutter. Cycles 3.4 renders
    it exactly as without motion blur (relMSE 0.00000 between the two): lights do not blur there."""
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    spot = scenes.add_light(scene, "Spot", 'SPOT', None, 300.0,
                            {"spot_size": 0.6, "spot_blend": 0.1, "shadow_soft_size": 0.0}, (0, 0, 2))
    linear(spot, "location", [(1, (-4, 0, 2)), (5, (4, 0, 2))])
    linear(spot, "rotation_euler", [(1, (0, -0.6, 0)), (5, (0, 0.6, 0))])
    scenes.add_camera(scene, (0, 0, 8), (0, 0, 0))
    scene.frame_set(3)


def checker_slider(scene):
    """A cube with a checker in Object coordinates (cells of a quarter unit) sliding one unit a
    frame, seen from above: the checker moves with the cube, so it blurs along x only."""
    _lit_floor(scene)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 0.5))
    cube = bpy.context.active_object
    m = scenes.diffuse_material("Checker")
    nt = m.node_tree
    tc, ck = nt.nodes.new("ShaderNodeTexCoord"), nt.nodes.new("ShaderNodeTexChecker")
    ck.inputs["Scale"].default_value = 4.0
    ck.inputs["Color1"].default_value = (0.9, 0.9, 0.9, 1)
    ck.inputs["Color2"].default_value = (0.05, 0.05, 0.05, 1)
    nt.links.new(tc.outputs["Object"], ck.inputs["Vector"])
    nt.links.new(ck.outputs["Color"], nt.nodes["Diffuse BSDF"].inputs["Color"])
    cube.data.materials.append(m)
    linear(cube, "location", [(1, (-2, 0, 0.5)), (5, (2, 0, 0.5))])
    scenes.add_camera(scene, (0, 0, 8), (0, 0, 0))
    scene.frame_set(3)


MOTION_SCENES = {"sliding_turning_cube": sliding_turning_cube, "falling_ball": falling_ball,
                 "panning_camera": panning_camera, "stretching_cube": stretching_cube,
                 "checker_slider": checker_slider}


@pytest.mark.parametrize("case", list(MOTION_SCENES))
def test_motion_blur_against_cycles(blur_scene, out_dir, case):
    from test_cycles_brightness import relmse
    MOTION_SCENES[case](blur_scene)
    blur_scene.render.resolution_x, blur_scene.render.resolution_y = MOTION_SIZE
    scenes.configure_cycles(blur_scene, CYCLES_SAMPLES, 4)
    cycles = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / f"{case}_cycles.exr")))
    blur_scene.render.engine = 'GRADPHOTON'
    g = blur_scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces, g.seed = 'pt', 'PASSES', GRADPHOTON_PASSES, 4, 1
    ours = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / f"{case}_gradphoton.exr")))
    blur_scene.render.use_motion_blur = False
    blur_scene.render.engine = 'CYCLES'
    sharp = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / f"{case}_sharp.exr")))
    ratio, err, err_sharp = ours.sum() / cycles.sum(), relmse(ours, cycles), relmse(sharp, cycles)
    print(f"MOTION {case}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f} (sharp frame vs blurred Cycles {err_sharp:.5f})")
    assert abs(ratio - 1) < MOTION_MEAN, f"{case}: gradphoton/Cycles mean = {ratio:.4f}"
    assert err < MOTION_RELMSE[case], f"{case}: relMSE {err:.5f} >= {MOTION_RELMSE[case]}"
    assert err_sharp > 2 * MOTION_RELMSE[case], f"{case}: the sharp frame is as close ({err_sharp:.5f}): no test of blur"


def test_moving_spot_as_cycles_unblurred_unless_asked(blur_scene, out_dir):
    """Cycles 3.4 does not blur a moving lamp (its render with Motion Blur on equals the one with
    it off); by default neither do we (relMSE within the blur cases' bound); with Blur Moving
    Lights the F12 render blurs the lit spot (further from Cycles than twice the bound)."""
    from test_cycles_brightness import relmse
    moving_spot(blur_scene)
    blur_scene.render.resolution_x, blur_scene.render.resolution_y = MOTION_SIZE
    scenes.configure_cycles(blur_scene, CYCLES_SAMPLES, 4)
    cycles = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / "spot_cycles.exr")))
    blur_scene.render.engine = 'GRADPHOTON'
    g = blur_scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces, g.seed = 'pt', 'PASSES', GRADPHOTON_PASSES, 4, 1
    ours = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / "spot_gradphoton.exr")))
    g.motion_blur_lights = True
    blurred = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / "spot_blurred.exr")))
    g.motion_blur_lights = False
    ratio, err, err_blur = ours.sum() / cycles.sum(), relmse(ours, cycles), relmse(blurred, cycles)
    print(f"MOTION moving_spot: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f} (blurred lights {err_blur:.5f})")
    # Measured: mean 0.984, relMSE 0.0063 (the spot's cone edge: the lamp is still, this is the
    # spot's own agreement with Cycles), 0.243 with the lights blurred. Bounds: twice that.
    assert abs(ratio - 1) < 0.032 and err < MOTION_RELMSE["moving_spot"], (ratio, err)
    assert err_blur > 2 * MOTION_RELMSE["moving_spot"]


def _combined(N, scene, passes=4):
    s = N.Session(scene, "pt", {"seed": 3, "threads": 2})
    for _ in range(passes):
        s.iterate()
    return s.develop()["combined"]


def test_json_export_renders_as_the_blender_export(blur_scene, out_dir):
    """File > Export > gradphoton Scene writes the motion (ExportedScene.to_json): the command
    line renders the file as the render from Blender renders its export."""
    sliding_turning_cube(blur_scene)
    wavy_plane(blur_scene)
    blur_scene.render.resolution_x, blur_scene.render.resolution_y = MOTION_SIZE
    path = str(out_dir / "moving.json")
    assert bpy.ops.gradphoton.export_scene(filepath=path) == {'FINISHED'}
    N = native.get()
    with open(path) as f:
        objects = {o["name"]: o for o in json.load(f)["objects"]}
    assert "motion" in objects["Cube"] and "motion_positions" in objects["Wavy"]
    direct, loaded = _combined(N, export_final().build(N)), _combined(N, N.load_scene(path))
    assert direct.mean() > 0.01
    np.testing.assert_allclose(loaded, direct, rtol=1e-4, atol=1e-5)


def test_batch_animation_renders_each_frame_blurred(blur_scene, out_dir):
    """`blender -b file -a`: each frame is sampled over its own shutter and the frame is restored
    for the next one: frame 3 of the animation is the F12 render of frame 3."""
    from test_render import batch_render
    sliding_turning_cube(blur_scene)
    blur_scene.gradphoton.passes = 4
    blur_scene.frame_start, blur_scene.frame_end = 2, 3
    blend = str(out_dir / "moving.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    r = batch_render(blend, str(out_dir / "anim_"), "-a")
    assert r.returncode == 0, r.stdout + r.stderr
    frames = [native.get().read_exr(str(out_dir / f"anim_000{f}.exr"))["ViewLayer.Combined"] for f in (2, 3)]
    blur_scene.frame_set(3)
    f12 = read_rgb(scenes.render_to_exr(blur_scene, str(out_dir / "f12.exr")))
    assert np.abs(frames[0] - frames[1]).mean() > 1e-3  # the cube moved between the frames
    np.testing.assert_allclose(frames[1][..., :3], f12, rtol=1e-5, atol=1e-6)
