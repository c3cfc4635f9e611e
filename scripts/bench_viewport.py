"""Rendered-viewport timings in Blender's real window (Xvfb): time to the first viewport image
(export, native build and the first reduced-resolution pass; and to the first full-resolution
pass), and the update time after a camera move, a material edit and an object move, each from
Blender's update to the first image that shows it (engine time, viewport.py's events); last, the
time per pass of the whole view and of a render region (a quarter of the camera frame).

    scripts/bench_viewport.sh                   # both scenes below, a table on stdout
    xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup SCENE.blend \\
        --python scripts/bench_viewport.py -- [--method pt] [--threads 0] [--repeat 3] [--move largest]

--move: the mesh the object move moves, `largest` (the dense sphere of cornell-dense) or
`smallest` (a small object beside a large one that stays).

SCENE.blend from scripts/json_to_blend.py (scenes/cornell-box.json: the demo scene;
scenes/cornell-dense.json: about 1 M triangles). The 3D view looks through the scene camera.
"""
import json
import os
import statistics
import sys
import time
import traceback

import bpy
import mathutils

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
import addon_utils  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def arg(name, default):
    return type(default)(args[args.index(name) + 1]) if name in args else default


METHOD, THREADS, REPEAT = arg("--method", "pt"), arg("--threads", 0), arg("--repeat", 3)
MOVE = arg("--move", "largest")
bpy.context.preferences.view.show_splash = False
addon_utils.enable("gradphoton", default_set=True)
from gradphoton import viewport as gp_viewport  # noqa: E402

scene = bpy.context.scene
scene.render.engine = "GRADPHOTON"
scene.gradphoton.viewport_method = METHOD
scene.gradphoton.threads = THREADS
scene.gradphoton.viewport_passes = 0
meshes = sorted((o for o in scene.objects if o.type == 'MESH'), key=lambda o: -len(o.data.polygons))
target = meshes[0] if MOVE == "largest" else meshes[-1]  # the mesh the object move moves
material = next(m for m in bpy.data.materials if m.node_tree and any(
    n.bl_idname == 'ShaderNodeBsdfPrincipled' for n in m.node_tree.nodes) and m.users)
bsdf = next(n for n in material.node_tree.nodes if n.bl_idname == 'ShaderNodeBsdfPrincipled')
out = {"scene": bpy.data.filepath, "method": METHOD, "threads": THREADS, "moved": target.name,
       "triangles": sum(len(o.data.loop_triangles) or len(o.data.polygons) * 2 for o in meshes), "runs": {}}
state = {"stage": 0, "t": time.perf_counter(), "i": 0}


def view3d():
    win = bpy.context.window_manager.windows[0]
    area = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
    return area


def vp():
    return gp_viewport.LAST


def settled():
    v = vp()
    return v is not None and v.image is not None and v.divider == 1 and v.request is None and v._full is None


def record(kind):
    for k, s in vp().events:
        if k.startswith(kind):
            out["runs"].setdefault(k, []).append(s)
    vp().events.clear()


def finish():
    summary = {k: {"median_s": statistics.median(v), "runs": len(v)} for k, v in out["runs"].items()}
    out["summary"] = summary
    print("BENCH_VIEWPORT " + json.dumps(out), flush=True)
    bpy.ops.wm.quit_blender()


ACTIONS = ["camera", "description", "transforms"]


def act(kind, i):
    area = view3d()
    if kind == "camera":
        # Leave the camera view for a turned user view (a new viewport camera each time).
        rv3d = area.spaces.active.region_3d
        rv3d.view_perspective = 'PERSP'
        rv3d.view_rotation.rotate(mathutils.Euler((0.0, 0.0, 0.05 * (1 if i % 2 else -1))))
        area.tag_redraw()
    elif kind == "description":
        c = 0.3 + 0.4 * (i % 2)
        bsdf.inputs["Base Color"].default_value = (c, 0.5, 0.5, 1.0)
    else:
        target.location.x += 0.05 * (1 if i % 2 else -1)


REGION = (0.25, 0.75, 0.25, 0.75)  # the render border (min x, max x, min y, max y of the camera frame)


def region_step(now):
    """Last, the time per full-resolution pass of the whole view and of a render region: the
    scene's render border, a quarter of the camera frame (the view looks through the camera)."""
    v = vp()
    if not state.get("camera_view"):  # (the camera moves above left the camera view)
        view3d().spaces.active.region_3d.view_perspective = 'CAMERA'
        view3d().tag_redraw()
        state.update(camera_view=True, t=now)
        return 0.5
    if not settled() or v.passes < 4:
        return 0.05
    if "full_pass_s" not in out:
        out["full_pass_s"], out["full_pixels"] = v.pass_seconds, v.image[1].shape[0] * v.image[1].shape[1]
        r = scene.render
        r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = REGION
        r.use_border = True
        view3d().tag_redraw()
        state["t"] = now
        return 0.05
    if v.image[2] is None:
        return 0.05
    out["region_pass_s"], out["region_pixels"] = v.pass_seconds, v.image[1].shape[0] * v.image[1].shape[1]
    out["region_placement"] = v.image[2]
    finish()
    return None


def step():
    try:
        now = time.perf_counter()
        if now - state["t"] > 120:
            out["error"] = f"timed out at stage {state['stage']}" + (f" ({vp().error})" if vp() and vp().error else "")
            finish()
            return None
        if state["stage"] == 0:
            area = view3d()
            sp = area.spaces.active
            sp.overlay.show_overlays = False
            sp.show_gizmo = False
            sp.region_3d.view_perspective = 'CAMERA'
            sp.shading.type = 'RENDERED'
            out["region"] = [r.width for r in area.regions if r.type == 'WINDOW'] + \
                            [r.height for r in area.regions if r.type == 'WINDOW']
            state.update(stage=1, t=now)
            return 0.05
        if state["stage"] == 1:  # the first image
            if not settled():
                return 0.02
            record("first")
            state.update(stage=2, t=now)
            return 0.5
        # Then each action REPEAT times, waiting for its full-resolution image.
        n = state["i"]
        if n >= REPEAT * len(ACTIONS):
            return region_step(now)
        if state.get("waiting"):
            if not settled():
                return 0.02
            record(state["waiting"])
            state["waiting"] = None
            state["i"] += 1
            return 0.3
        kind = ACTIONS[n % len(ACTIONS)]
        act(kind, n)
        state.update(waiting=kind, t=now)
        return 0.02
    except Exception:
        out["error"] = traceback.format_exc()
        finish()
        return None


bpy.app.timers.register(step, first_interval=1.0)
