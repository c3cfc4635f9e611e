"""The panels a Cycles user reaches for, in Blender's real window, and a Holdout render by F12 (run
under Xvfb by tests/blender/test_ui.py):

    xvfb-run -a -s "-screen 0 1920x1400x24" blender --factory-startup --python tests/blender/ui_cycles_panels.py -- OUT_DIR

The factory scene with gradphoton, a floor under the cube, the cube set to Mask > Holdout. The
Properties editor shows the Object tab (Visibility with its Ray Visibility sub-panel), the World
tab (Ray Visibility) and the Render tab (Film: Exposure, Pixel Filter, Transparent); those panels
are Blender's closed-by-default ones, so this script registers them open (in this Blender only).
Each tab is saved as OUT_DIR/cycles_<name>.png. Then F12 (render.render INVOKE_DEFAULT in the
window) renders with Film > Transparent; the Render Result is saved as OUT_DIR/cycles_holdout.exr
and what it shows is written to OUT_DIR/ui_cycles_panels.json. Draw errors reach stderr, which the
test reads."""
import json
import os
import sys
import traceback

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
import addon_utils  # noqa: E402

OUT = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "/tmp"
addon_utils.enable("gradphoton", default_set=True)
from gradphoton import native, session as gp_session  # noqa: E402


def open_by_default(parent_name):
    """Registers a closed-by-default panel (and its sub-panels) again, open."""
    parent = getattr(bpy.types, parent_name)
    children = [c for c in bpy.types.Panel.__subclasses__() if getattr(c, "bl_parent_id", "") == parent_name
                and hasattr(bpy.types, c.__name__)]
    for c in children:
        bpy.utils.unregister_class(c)
    bpy.utils.unregister_class(parent)
    parent.bl_options = set(getattr(parent, "bl_options", set())) - {'DEFAULT_CLOSED'}
    bpy.utils.register_class(parent)
    for c in children:
        bpy.utils.register_class(c)


for name in ("OBJECT_PT_visibility", "GRADPHOTON_WORLD_PT_ray_visibility", "GRADPHOTON_PT_film"):
    open_by_default(name)

scene = bpy.context.scene
scene.render.engine = "GRADPHOTON"
scene.gradphoton.method = "pt"
scene.gradphoton.stop_rule = 'PASSES'
scene.gradphoton.passes = 4
scene.gradphoton.threads = 1
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 160, 120, 100
scene.render.film_transparent = True
bpy.context.preferences.view.render_display_type = 'WINDOW'
cube = bpy.data.objects["Cube"]
cube.is_holdout = True
bpy.ops.mesh.primitive_plane_add(size=60, location=(0, 0, -1))
floor = bpy.context.object
world = scene.world or bpy.data.worlds.new("World")
scene.world = world
TABS = [("object", 'OBJECT', cube), ("world", 'WORLD', cube), ("render", 'RENDER', cube)]
result = {"ok": False, "tabs": {}}
state = {"i": 0, "shown": False, "render": None}


def properties_area():
    win = bpy.context.window_manager.windows[0]
    return win, max((a for a in win.screen.areas if a.type == 'PROPERTIES'), key=lambda a: a.height)


def finish():
    with open(os.path.join(OUT, "ui_cycles_panels.json"), "w") as f:
        json.dump(result, f, indent=1)
    bpy.ops.wm.quit_blender()


def on_complete(*_):
    state["render"] = "done"


bpy.app.handlers.render_complete.append(on_complete)


def check_render():
    """The Render Result: alpha 0 and black at the cube (the image centre), alpha 1 on the floor
    (the bottom rows), no warning about Holdout."""
    import numpy as np
    path = os.path.join(OUT, "cycles_holdout.exr")
    scene.render.image_settings.file_format = 'OPEN_EXR'
    bpy.data.images["Render Result"].save_render(path)
    exr = native.get().read_exr(path)
    rgb = exr["combined"] if "combined" in exr else np.dstack([exr[c][..., 0] for c in "RGB"])
    a = exr["A"][..., 0]
    h, w = a.shape
    centre = (slice(h // 2 - 3, h // 2 + 3), slice(w // 2 - 3, w // 2 + 3))
    result["holdout"] = {"centre_alpha_max": float(a[centre].max()), "centre_rgb_max": float(np.abs(rgb[centre]).max()),
                         "floor_alpha_min": float(a[-3:].min()), "floor_rgb_mean": float(rgb[-3:].mean()),
                         "reports": [m for _, m in gp_session.REPORTS]}


def step():
    try:
        win, area = properties_area()
        if state["i"] < len(TABS):
            name, context, ob = TABS[state["i"]]
            if bpy.context.view_layer.objects.active != ob:
                bpy.context.view_layer.objects.active = ob
                for o in bpy.context.view_layer.objects:
                    o.select_set(o == ob)
                area.tag_redraw()
                return 0.5
            if not state["shown"]:
                area.spaces.active.context = context
                area.tag_redraw()
                state["shown"] = True
                return 0.8
            path = os.path.join(OUT, f"cycles_{name}.png")
            with bpy.context.temp_override(window=win, area=area):
                bpy.ops.screen.screenshot_area(filepath=path)
            result["tabs"][name] = {"context": area.spaces.active.context, "png": os.path.exists(path)}
            state["i"] += 1
            state["shown"] = False
            return 0.1
        if state["render"] is None:
            big = max(win.screen.areas, key=lambda a: a.width * a.height)
            with bpy.context.temp_override(window=win, area=big, screen=win.screen):
                bpy.ops.render.render('INVOKE_DEFAULT')
            state["render"] = "running"
            return 0.5
        if state["render"] == "done" and not bpy.app.is_job_running('RENDER'):
            check_render()
            result["ok"] = True
            finish()
            return None
        return 0.2
    except Exception:
        result["error"] = traceback.format_exc()
        finish()
        return None


bpy.app.timers.register(step, first_interval=2.0)
