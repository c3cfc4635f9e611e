"""Persistent Data (the native scene kept between frames, only what changed updated), border
renders that trace only the border, the animated seed, and sync.py's plans."""
import bpy
import numpy as np
import pytest

import scenes
from gradphoton import native, session, sync


def scene_with_cube(scene):
    scenes.add_plane(scene, "Floor", 10.0, scenes.diffuse_material("Floor"))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    cube = bpy.context.active_object
    cube.data.materials.append(scenes.diffuse_material("Red", (0.8, 0.1, 0.1)))
    la = bpy.data.lights.new("Sun", 'SUN')
    la.energy = 3.0
    sun = bpy.data.objects.new("Sun", la)
    scene.collection.objects.link(sun)
    sun.rotation_euler = (0.5, 0.3, 0)
    scenes.add_camera(scene, (0, -6, 3), (0, 0, 0.5))
    return cube


def render_combined():
    bpy.ops.render.render()
    s = session.LAST
    images = s.session.develop()
    return s, images["combined"]


def test_persistent_data_updates_the_kept_scene_and_renders_as_a_fresh_export(empty_scene):
    cube = scene_with_cube(empty_scene)
    cube.location.x = 0.0
    cube.keyframe_insert("location", frame=1)
    cube.location.x = 1.0
    cube.keyframe_insert("location", frame=2)
    empty_scene.render.use_persistent_data = True
    empty_scene.frame_set(1)
    s1, _ = render_combined()
    engine_state = s1.engine.persistent
    empty_scene.frame_set(2)
    s2, moved = render_combined()
    assert s2.engine.persistent is engine_state  # Blender kept the engine and the native scene
    # Frame 2: the cube's matrix only, no mesh read from Blender again.
    assert engine_state.plans == [["rebuild"], ["transforms"]], engine_state.plans
    assert engine_state.sync.cache.misses == 0
    # A material edit between frames is a description update of the same scene.
    bpy.data.materials["Red"].node_tree.nodes["Diffuse BSDF"].inputs["Color"].default_value = (0.1, 0.1, 0.8, 1)
    s3, blue = render_combined()
    assert engine_state.plans[-1] == ["description"], engine_state.plans
    assert blue[..., 2].mean() > moved[..., 2].mean()
    # The same frame without persistent data: the same image, but for the last bits of the moved
    # cube's hits (an Embree instance traces it in object space; scene_update_test.cpp's
    # expect_close): the same paths, values within 1e-4, at most 1 % sent elsewhere by a last bit.
    empty_scene.render.use_persistent_data = False
    s4, fresh = render_combined()
    off = ~(np.abs(blue - fresh) <= 1e-4 * np.abs(fresh) + 1e-7)
    assert off.mean() <= 0.01, off.mean()


def test_persistent_data_reexports_an_edited_mesh(empty_scene):
    cube = scene_with_cube(empty_scene)
    empty_scene.render.use_persistent_data = True
    s1, before = render_combined()
    state = s1.engine.persistent
    for v in cube.data.vertices:  # a taller cube: its geometry changed
        v.co.z *= 2.0
    cube.data.update()
    s2, after = render_combined()
    assert state.plans[-1] == ["rebuild"] and state.sync.cache.misses == 1, (state.plans, state.sync.cache.misses)
    assert not np.array_equal(before, after)


def test_border_render_traces_only_the_border(empty_scene):
    scene_with_cube(empty_scene)
    r = empty_scene.render
    r.resolution_x, r.resolution_y = 40, 30
    empty_scene.gradphoton.passes = 3
    s_full, _ = render_combined()
    r.use_border, r.use_crop_to_border = True, True
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.2, 0.6
    s_crop, crop = render_combined()
    w, h = int(0.75 * 40) - int(0.25 * 40), int(0.6 * 30) - int(0.2 * 30)
    assert crop.shape[:2] == (h, w)
    # One path per traced pixel and pass: the border's pixels only.
    assert s_full.session.stats["paths"] == 40 * 30 * 3
    assert s_crop.session.stats["paths"] == w * h * 3


def test_animated_seed_changes_with_the_frame(empty_scene):
    s = empty_scene.gradphoton
    s.seed = 5
    assert session.params_of(s, "pt", frame=1)["seed"] == session.params_of(s, "pt", frame=2)["seed"] == 5
    s.use_animated_seed = True
    seeds = {session.params_of(s, "pt", frame=f)["seed"] for f in range(1, 50)}
    assert len(seeds) == 49 and all(0 <= x < 2 ** 31 for x in seeds)
    assert session.params_of(s, "pt", frame=7)["seed"] == session.params_of(s, "pt", frame=7)["seed"]
    scene_with_cube(empty_scene)
    empty_scene.frame_set(1)
    _, a = render_combined()
    empty_scene.frame_set(2)
    _, b = render_combined()
    assert not np.array_equal(a, b)  # nothing moved: only the noise differs


def test_sync_plans_a_rebuild_then_only_what_changed(empty_scene):
    cube = scene_with_cube(empty_scene)
    sc = sync.SceneSync()
    dg = bpy.context.evaluated_depsgraph_get()
    first = sc.sync(dg, first=True)
    assert first.kinds() == ["rebuild"]
    N = native.get()
    nscene = sync.apply(first, None, N)
    names = nscene.mesh_names
    assert sc.sync(dg).empty  # nothing changed
    cube.location.z += 1.0
    dg = bpy.context.evaluated_depsgraph_get()
    moved = sc.sync(dg)
    assert moved.kinds() == ["transforms"]
    assert [names[i] for i in moved.transforms[0]] == ["Cube"]
    sync.apply(moved, nscene, N)
    assert nscene.meshes()[names.index("Cube")]["positions"][:, 2].min() == pytest.approx(1.0, abs=1e-5)
    bpy.data.objects["Sun"].data.energy = 5.0
    dg = bpy.context.evaluated_depsgraph_get()
    assert sc.sync(dg).kinds() == ["description"]
    cube.data.materials[0] = scenes.diffuse_material("Other")  # another material in the slot
    dg = bpy.context.evaluated_depsgraph_get()
    assert sc.sync(dg).kinds() == ["rebuild"]


def test_viewport_render_region_at_reduced_resolution_covers_the_region():
    """viewport.scaled_crop: the reduced passes of a render region trace whole reduced pixels that
    cover the region, inside the reduced image; at full resolution the region itself."""
    from gradphoton import viewport
    rng = np.random.default_rng(3)
    for _ in range(200):
        W, H = int(rng.integers(1, 1500)), int(rng.integers(1, 900))
        x, y = int(rng.integers(0, W)), int(rng.integers(0, H))
        crop = [x, y, int(rng.integers(1, W - x + 1)), int(rng.integers(1, H - y + 1))]
        assert viewport.scaled_crop(crop, W, H, 1) == (crop, W, H)
        for d in viewport.dividers(W, H):
            (cx, cy, cw, ch), rw, rh = viewport.scaled_crop(crop, W, H, d)
            assert cw >= 1 and ch >= 1 and cx + cw <= rw and cy + ch <= rh, (crop, W, H, d)
            # Scaled back (a reduced pixel is W / rw view pixels wide), it covers the region.
            sx, sy = W / rw, H / rh
            assert cx * sx <= crop[0] + 1e-9 and cy * sy <= crop[1] + 1e-9, (crop, W, H, d)
            assert (cx + cw) * sx >= crop[0] + crop[2] - 1e-9 and (cy + ch) * sy >= crop[1] + crop[3] - 1e-9, \
                (crop, W, H, d)
            assert cw * sx <= crop[2] + 2 * sx and ch * sy <= crop[3] + 2 * sy  # and not much more
