"""UI test in Blender's real window (run under Xvfb by tests/blender/test_ui.py):

    xvfb-run -a blender --factory-startup --enable-event-simulate --python tests/blender/ui_test.py -- OUT_DIR

Opens a scene, presses F12 (the normal invoked render, in a new render window), checks that the
Render Result is updated progressively, presses Esc, checks the render stops quickly and keeps
its passes, saves a screenshot of the render window and the image, writes OUT_DIR/ui_result.json.
Keys are real X key presses through xdotool (XTEST), as a user's: F12 in the main window, Esc
in the render window (Esc must reach Blender as a window-system event to break a render job)."""
import faulthandler
import json
import os
import subprocess
import sys
import time
import traceback

import bpy

faulthandler.enable(all_threads=True)  # a crash prints every thread's Python stack (test_ui.py)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
import addon_utils  # noqa: E402

OUT = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else "/tmp"
addon_utils.enable("gradphoton", default_set=True)
from gradphoton import session as gp_session  # noqa: E402

result = {"ok": False, "steps": []}
state = {"t0": None, "esc_at": None, "cancel_at": None, "done": False}


def log(msg):
    result["steps"].append(f"{time.perf_counter():.3f} {msg}")
    print("UI:", msg, flush=True)


def on_cancel(*_):
    state["cancel_at"] = time.perf_counter()


def on_complete(*_):
    state["done"] = True


bpy.app.handlers.render_cancel.append(on_cancel)
bpy.app.handlers.render_complete.append(on_complete)

scene = bpy.context.scene  # the factory scene: cube, light, camera
scene.render.engine = "GRADPHOTON"
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 480, 270, 100
scene.gradphoton.stop_rule = 'TIME'
scene.gradphoton.time_limit = 60.0
scene.gradphoton.threads = 1  # leave a core to the UI (software OpenGL draws on the CPU)
bpy.context.preferences.view.render_display_type = 'WINDOW'


def finish():
    with open(os.path.join(OUT, "ui_result.json"), "w") as f:
        json.dump(result, f, indent=1)
    bpy.ops.wm.quit_blender()


def screenshot(name):
    for win in bpy.context.window_manager.windows:
        if any(a.type == 'IMAGE_EDITOR' for a in win.screen.areas):
            area = next(a for a in win.screen.areas if a.type == 'IMAGE_EDITOR')
            with bpy.context.temp_override(window=win, area=area):
                bpy.ops.screen.screenshot_area(filepath=os.path.join(OUT, name))
            return True
    return False


def press(key):
    """A real key press in the focused (newest) Blender window, with the pointer over it."""
    cmd = ("w=$(xdotool search --onlyvisible --name 'Blender' | tail -1); xdotool windowfocus --sync $w; "
           "xdotool mousemove --window $w 200 150; xdotool key --window $w " + key + "; date +%s.%N")
    return subprocess.Popen(["sh", "-c", cmd], stdout=subprocess.PIPE, text=True)


def step():
    try:
        now = time.perf_counter()
        wm = bpy.context.window_manager
        if state["t0"] is None:
            press("F12")
            state["t0"] = now
            log("pressed F12")
            return 0.2
        if state.get("invoked") is None:
            running = bpy.app.is_job_running('RENDER')
            if running:
                state["invoked"] = "F12 key"
                log(f"render job running after {now - state['t0']:.1f} s ({len(wm.windows)} windows)")
            elif now - state["t0"] > 3:
                # The simulated key was not taken (no window focus under Xvfb): invoke the same
                # operator F12 calls, in the window, as the key map does.
                win = wm.windows[0]
                area = max(win.screen.areas, key=lambda a: a.width * a.height)
                with bpy.context.temp_override(window=win, area=area, screen=win.screen):
                    bpy.ops.render.render('INVOKE_DEFAULT')
                state["invoked"] = "render.render INVOKE_DEFAULT"
                log("F12 not taken; invoked render.render('INVOKE_DEFAULT')")
            return 0.1
        result["invoked_by"] = state["invoked"]
        s = gp_session.LAST
        updates = list(s.updates) if s else []
        if state["esc_at"] is None:
            if len(updates) >= 3 and updates[-1][1] > updates[0][1]:
                result["updates_before_esc"] = updates
                result["render_windows"] = len(wm.windows)
                result["screenshot"] = screenshot("ui_render_window_progress.png")
                state["esc_at"] = time.perf_counter()
                state["esc_proc"] = press("Escape")
                log(f"pressed Esc after {len(updates)} progressive updates")
            elif now - state["t0"] > 45:
                log(f"no progressive updates: {updates}")
                finish()
                return None
            return 0.05
        if state["cancel_at"] is not None or state["done"] or (s and s.cancel_latency is not None):
            if not bpy.app.is_job_running('RENDER'):
                stopped = state["cancel_at"] or time.perf_counter()
                # From the moment xdotool had sent Esc (wall clock) to Blender's render_cancel.
                sent = float(state["esc_proc"].communicate()[0].strip())
                result["esc_to_stop_s"] = (time.time() - (time.perf_counter() - stopped)) - sent
                result["esc_to_test_break_s"] = s.break_at - sent if s.break_at else None
                result["esc_to_engine_return_s"] = s.finished_at - sent if s.finished_at else None
                result["esc_command_s"] = stopped - state["esc_at"]
                result["engine_cancel_latency_s"] = s.cancel_latency
                result["passes"] = s.session.stats["passes"]
                path = os.path.join(OUT, "ui_render_result.exr")
                img = bpy.data.images["Render Result"]
                scene.render.image_settings.file_format = 'OPEN_EXR'
                img.save_render(path)
                result["image_saved"] = os.path.exists(path)
                screenshot("ui_render_window_after_esc.png")
                result["ok"] = True
                log("render stopped")
                finish()
                return None
        if now - state["esc_at"] > 10:
            log("Esc did not stop the render")
            finish()
            return None
        return 0.02
    except Exception:
        result["error"] = traceback.format_exc()
        finish()
        return None


bpy.app.timers.register(step, first_interval=2.0)
