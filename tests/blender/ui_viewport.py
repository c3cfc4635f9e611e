"""The rendered viewport in Blender's real window (run under Xvfb by tests/blender/test_ui.py):

    xvfb-run -a blender --factory-startup --python tests/blender/ui_viewport.py -- OUT_DIR

Switches the factory scene's 3D view to Rendered shading (overlays, gizmos, header and side
regions off, so the area shows only the drawn image), waits for the progressive image, takes
screenshots of the area, then edits the cube's material colour, moves the cube, turns the view,
sets a render region (View > Render Region) and leaves Rendered shading; each change must reach
the screen (the screenshot changes as the edit says: with a render region, the image only inside
it) and leaving must stop the worker. Writes OUT_DIR/ui_viewport.json."""
import faulthandler
import json
import os
import sys
import time
import traceback
import types

import bpy
import numpy as np

faulthandler.enable(all_threads=True)  # a crash prints every thread's Python stack (test_ui.py)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
import addon_utils  # noqa: E402

OUT = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "/tmp"
addon_utils.enable("gradphoton", default_set=True)
from gradphoton import viewport as gp_viewport  # noqa: E402

result = {"ok": False, "steps": [], "shots": {}}
state = {"stage": "start", "t": time.perf_counter()}

bpy.context.preferences.view.show_splash = False  # it would cover the view
scene = bpy.context.scene  # the factory scene: cube, light, camera
scene.render.engine = "GRADPHOTON"
scene.gradphoton.viewport_method = "pt"
scene.gradphoton.threads = 1          # leave a core to the UI (software OpenGL draws on the CPU)
scene.gradphoton.pt.max_bounces = 3  # the viewport renders with pt: its own parameters
scene.gradphoton.viewport_passes = 0  # keep refining: the test checks the count grows
material = bpy.data.materials["Material"]
base_color = material.node_tree.nodes["Principled BSDF"].inputs["Base Color"]
base_color.default_value = (0.8, 0.8, 0.8, 1.0)
cube = bpy.data.objects["Cube"]


def log(msg):
    result["steps"].append(f"{time.perf_counter():.3f} {msg}")
    print("UI:", msg, flush=True)


def finish():
    with open(os.path.join(OUT, "ui_viewport.json"), "w") as f:
        json.dump(result, f, indent=1)
    bpy.ops.wm.quit_blender()


def view3d():
    win = bpy.context.window_manager.windows[0]
    area = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
    return win, area


def screenshot(name):
    """The 3D view's area as Blender draws it: (H, W, 3) floats in [0, 1], top row first."""
    win, area = view3d()
    path = os.path.join(OUT, name)
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.screen.screenshot_area(filepath=path)
    img = bpy.data.images.load(path, check_existing=False)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    h, w = img.size[1], img.size[0]
    bpy.data.images.remove(img)
    a = px.reshape(h, w, 4)[::-1, :, :3]
    # Skip the area's 1-pixel borders.
    a = a[2:-2, 2:-2]
    result["shots"][name] = {"mean": a.mean(axis=(0, 1)).tolist(), "std": float(a.std())}
    return a


def vp():
    return gp_viewport.LAST


def setup():
    win, area = view3d()
    space = area.spaces.active
    space.overlay.show_overlays = False
    space.show_gizmo = False
    space.show_region_header = False
    space.show_region_toolbar = False
    space.show_region_ui = False
    space.region_3d.view_distance = 7.0  # the cube large in the view
    space.shading.type = 'RENDERED'
    log(f"3D view {area.width}x{area.height} in Rendered shading")


def wait_for(pred, stage, timeout=30.0):
    if pred():
        return True
    if time.perf_counter() - state["t"] > timeout:
        v = vp()
        log(f"timed out waiting in stage {stage}" + ("" if v is None else
            f" (passes {v.passes}, divider {v.divider}, request {v.request}, image "
            f"{None if v.image is None else v.image[0]}, drawn {v._texture_serial}, "
            f"redraw wanted {v.redraw_wanted}, stopped {v.stopped}, error {v.error})"))
        result["timeout"] = stage
        finish()
        raise StopIteration
    return False


def next_stage(name):
    state["stage"], state["t"] = name, time.perf_counter()
    state.pop("drawn", None)
    log(f"stage {name}")


def image_serial():
    v = vp()
    return v.image[0] if v is not None and v.image is not None else -1


def settled(min_passes=2):
    v = vp()
    if not (v is not None and v.image is not None and v.divider == 1 and v.passes >= min_passes and
            v.request is None):
        return False
    # ... and drawn: the view's texture holds that image or a later one (the screenshot shows it;
    # the worker keeps publishing meanwhile).
    need = state.setdefault("drawn", v.image[0])
    return v._texture_serial >= need


REGION = (0.3, 0.7, 0.25, 0.75)  # the view's render region: min x, max x, min y, max y (fractions)


def pixels_of_image():
    v = vp()
    return int(v.image[1].shape[0] * v.image[1].shape[1])


def region_checks(shot, full):
    """The screenshot with a render region against the last one without: the image inside the
    region (close to the full view's there: the same camera), the view's own background outside
    (none of the red cube that the full view shows there), and only the region's pixels traced."""
    h, w = shot.shape[:2]
    x0, x1, y0, y1 = REGION
    # (top row first; 3 pixels of margin for the region's rounding and the area's borders)
    r0, r1 = int((1 - y1) * h) + 3, int((1 - y0) * h) - 3
    c0, c1 = int(x0 * w) + 3, int(x1 * w) - 3
    inside = np.zeros((h, w), bool)
    inside[r0:r1, c0:c1] = True
    outside = np.ones((h, w), bool)
    outside[r0 - 6:r1 + 6, c0 - 6:c1 + 6] = False
    result["region_inside_std"] = float(shot[inside].std())
    result["region_inside_change"] = float(np.abs(shot[inside] - full[inside]).mean())
    result["region_outside_change"] = float(np.abs(shot[outside] - full[outside]).mean())
    # (Blender draws the region's dashed red outline: the margin above leaves it out.)
    red = lambda a: float((a[outside][:, 0] - a[outside][:, 1] > 0.1).mean())  # noqa: E731
    result["region_outside_red"], result["full_outside_red"] = red(shot), red(full)
    result["region_pixels"] = pixels_of_image()
    result["full_pixels"] = state["full_pixels"]


def step():
    try:
        st = state["stage"]
        if st == "start":
            setup()
            next_stage("first image")
            return 0.1
        if st == "first image":
            if not wait_for(lambda: settled(2), st):
                return 0.05
            v = vp()
            result["first_image_s"] = dict(v.events).get("first")
            result["reduced_resolution_first"] = any(k == "first" for k, _ in v.events)
            result["passes_at_first_shot"] = v.passes
            state["grey"] = screenshot("viewport_rendered.png")
            state["passes"] = v.passes
            next_stage("refining")
            return 0.5
        if st == "refining":
            if not wait_for(lambda: vp().passes > state["passes"] + 2, st):
                return 0.1
            result["passes_later"] = vp().passes
            result["full_view_pass_s"] = vp().pass_seconds  # (docs/blender.md; not asserted)
            state["edit_serial"] = image_serial()
            base_color.default_value = (0.9, 0.05, 0.05, 1.0)  # a material edit: red
            log("material colour set to red")
            next_stage("material edit")
            return 0.05
        if st == "material edit":
            if not wait_for(lambda: any(k == "description" for k, _ in vp().events) and settled(1), st):
                return 0.05
            result["material_update_s"] = [s for k, s in vp().events if k == "description"][-1]
            red = screenshot("viewport_after_material_edit.png")
            grey = state["grey"]
            # The cube turned red: more red than green where it is, and the image changed.
            result["red_minus_green_before"] = float((grey[..., 0] - grey[..., 1]).mean())
            result["red_minus_green_after"] = float((red[..., 0] - red[..., 1]).mean())
            state["red"] = red
            cube.location.x += 1.5
            log("cube moved")
            next_stage("object move")
            return 0.05
        if st == "object move":
            if not wait_for(lambda: any(k == "transforms" for k, _ in vp().events) and settled(1), st):
                return 0.05
            result["object_move_s"] = [s for k, s in vp().events if k == "transforms"][-1]
            moved = screenshot("viewport_after_object_move.png")
            result["object_move_change"] = float(np.abs(moved - state["red"]).mean())
            state["moved"] = moved
            result["rebuilds"] = vp().sync.cache.misses  # meshes read from Blender by the last sync
            win, area = view3d()
            rv3d = area.spaces.active.region_3d
            rv3d.view_rotation.rotate(__import__("mathutils").Euler((0.0, 0.0, 0.6)))
            area.tag_redraw()
            log("view turned")
            next_stage("camera move")
            return 0.05
        if st == "camera move":
            if not wait_for(lambda: any(k == "camera" for k, _ in vp().events) and settled(1), st):
                return 0.05
            result["camera_move_s"] = [s for k, s in vp().events if k == "camera"][-1]
            turned = screenshot("viewport_after_view_turn.png")
            result["camera_move_change"] = float(np.abs(turned - state["moved"]).mean())
            state["turned"] = turned
            state["full_pixels"] = pixels_of_image()
            win, area = view3d()
            space = area.spaces.active
            (space.render_border_min_x, space.render_border_max_x,
             space.render_border_min_y, space.render_border_max_y) = REGION
            space.use_render_border = True
            area.tag_redraw()
            log("render region set")
            next_stage("render region")
            return 0.05
        if st == "render region":
            # ... and the region's own image published (a screenshot taken while the full view's
            # image was still the latest read 0.8 of its pixels once in CI).
            if not wait_for(lambda: vp().image[2] is not None and settled(3) and
                            pixels_of_image() < 0.25 * state["full_pixels"], st):
                return 0.05
            result["region_pass_s"] = vp().pass_seconds
            shot = screenshot("viewport_render_region.png")
            region_checks(shot, state["turned"])
            # Through the scene camera the scene's render border applies, not the view's region.
            r = scene.render
            r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.25, 0.75
            r.use_border = True
            win, area = view3d()
            area.spaces.active.region_3d.view_perspective = 'CAMERA'
            area.tag_redraw()
            state["view_region_placement"] = vp().image[2]
            log("camera view with a render border")
            next_stage("camera border")
            return 0.05
        if st == "camera border":
            if not wait_for(lambda: vp().image[2] not in (None, state["view_region_placement"]) and settled(1), st):
                return 0.05
            win, area = view3d()
            region = next(r for r in area.regions if r.type == 'WINDOW')
            ctx = types.SimpleNamespace(region=region, region_data=area.spaces.active.region_3d)
            fx0, fy0, fx1, fy1 = gp_viewport.camera_frame(ctx, scene)
            _, _, pw, ph = vp().image[2]
            # The border's share of the view: a quarter of the camera frame's.
            result["camera_border_share"] = pw * ph / ((fx1 - fx0) * (fy1 - fy0) / (region.width * region.height))
            screenshot("viewport_camera_border.png")
            state["worker"] = vp().thread
            area.spaces.active.shading.type = 'SOLID'
            log("left Rendered shading")
            next_stage("leave")
            return 0.05
        if st == "leave":
            if not wait_for(lambda: not state["worker"].is_alive(), st, timeout=5.0):
                return 0.05
            v = vp()
            result["worker_stop_s"] = v.exited_at - v.freed_at if v.freed_at and v.exited_at else None
            result["events"] = vp().events
            result["ok"] = True
            log("worker stopped")
            finish()
            return None
        return 0.1
    except StopIteration:
        return None
    except Exception:
        result["error"] = traceback.format_exc()
        finish()
        return None


bpy.app.timers.register(step, first_interval=1.0)
