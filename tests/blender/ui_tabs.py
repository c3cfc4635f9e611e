"""Screenshots of the Render, Light and Material tabs in Blender's real window (run under Xvfb by
tests/blender/test_ui.py):

    xvfb-run -a -s "-screen 0 1920x1400x24" blender --factory-startup --python tests/blender/ui_tabs.py -- OUT_DIR

The factory scene (cube, light, camera) with gradphoton as the engine; the Properties editor at
its default width shows each tab in turn; each is saved as OUT_DIR/tab_<name>.png and what was
shown is written to OUT_DIR/ui_tabs.json. Draw errors of the addon reach stderr, which the test reads."""
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

scene = bpy.context.scene
scene.render.engine = "GRADPHOTON"
scene.gradphoton.method = "sppm"
light = bpy.data.objects["Light"]
cube = bpy.data.objects["Cube"]
# (tab, Properties context, active object)
TABS = [("render", 'RENDER', cube), ("light", 'DATA', light), ("material", 'MATERIAL', cube)]
result = {"ok": False, "tabs": {}}
state = {"i": 0, "shown": False}


def properties_area():
    win = bpy.context.window_manager.windows[0]
    return win, max((a for a in win.screen.areas if a.type == 'PROPERTIES'), key=lambda a: a.height)


def finish():
    with open(os.path.join(OUT, "ui_tabs.json"), "w") as f:
        json.dump(result, f, indent=1)
    bpy.ops.wm.quit_blender()


def step():
    try:
        win, area = properties_area()
        name, context, ob = TABS[state["i"]]
        if bpy.context.view_layer.objects.active != ob:
            bpy.context.view_layer.objects.active = ob
            for o in bpy.context.view_layer.objects:
                o.select_set(o == ob)
            area.tag_redraw()
            return 0.5  # the editor offers the object's tabs once it has redrawn
        if not state["shown"]:
            area.spaces.active.context = context
            area.tag_redraw()
            state["shown"] = True
            return 0.7  # let the window draw the tab
        path = os.path.join(OUT, f"tab_{name}.png")
        with bpy.context.temp_override(window=win, area=area):
            bpy.ops.screen.screenshot_area(filepath=path)
        result["tabs"][name] = {"context": area.spaces.active.context, "width": area.width, "height": area.height,
                                "png": os.path.exists(path)}
        state["i"] += 1
        state["shown"] = False
        if state["i"] == len(TABS):
            result["ok"] = True
            finish()
            return None
        return 0.1
    except Exception:
        result["error"] = traceback.format_exc()
        finish()
        return None


bpy.app.timers.register(step, first_interval=2.0)
