"""F12 in Blender's real window, Cycles or gradphoton: when each image reached the render window.

    blender -b --factory-startup --python scripts/json_to_blend.py -- scenes/cornell-box.json /tmp/cb.blend
    xvfb-run -a -s "-screen 0 1920x1200x24" blender --factory-startup /tmp/cb.blend --debug-cycles --verbose 4 \\
        --python scripts/bench_f12_window.py -- --engine CYCLES --seconds 10 [--size 1920x1080] [--threads 2] [--keep-log]
    xvfb-run -a -s "-screen 0 1920x1200x24" blender --factory-startup /tmp/cb.blend \\
        --python scripts/bench_f12_window.py -- --engine GRADPHOTON --method sppm --seconds 10 [--size ...]

(not -b: Cycles sends images to Blender only when it has a display; in background mode it writes
the result once, at the end.) The script opens the render window as F12 does
(render.render INVOKE_DEFAULT, Preferences > Interface > Render In: New Window), renders for
--seconds (Cycles: Time Limit, samples unbounded, no denoising; gradphoton: the Time stop rule)
and prints when each image reached Blender, from the operator's call:
  - Cycles: the ends of its display updates in its log (render_scheduler.cpp's "Average display
    update time" line, which follows each update of the render result and its display:
    path_trace.cpp's "Invoke buffer update callback."; --debug-cycles --verbose 4 prints them,
    with the time), read from this process's stderr, which the script sends to a file while the
    render runs;
  - gradphoton: the end of each develop + copy into the render result (session.py's _write,
    which update_result follows at once), as scripts/bench_f12.py.
The window's own drawing (software OpenGL under Xvfb) comes after both. Then Blender quits.
"""
import datetime
import os
import re
import sys
import tempfile
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_utils  # noqa: E402
from f12_images import mark_images  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def arg(name, default, kind=str):
    return kind(args[args.index(name) + 1]) if name in args else default


engine = arg("--engine", "GRADPHOTON").upper()
method = arg("--method", "pt")
threads = arg("--threads", 2, int)
seconds = arg("--seconds", 10.0, float)
size = arg("--size", "")

addon_utils.enable("gradphoton", default_set=False)
from gradphoton import session  # noqa: E402

images = mark_images(session)  # gradphoton: perf_counter at the end of each develop + copy

scene = bpy.context.scene
scene.render.engine = engine
if size:
    scene.render.resolution_x, scene.render.resolution_y = (int(v) for v in size.split("x"))
    scene.render.resolution_percentage = 100
scene.render.threads_mode = 'FIXED'
scene.render.threads = threads
scene.render.use_persistent_data = False
if engine == 'CYCLES':
    c = scene.cycles
    c.device = 'CPU'
    c.samples = 1 << 20
    c.time_limit = seconds
    c.use_denoising = False
    c.use_adaptive_sampling = False
else:
    g = scene.gradphoton
    g.method, g.stop_rule, g.time_limit = method, 'TIME', seconds
    if hasattr(g, "threads"):
        g.threads = threads
bpy.context.preferences.view.render_display_type = 'WINDOW'

state = {"t0": None, "wall0": None, "log": None, "saved_fd": None, "done": False}


def on_done(*_):
    state["done"] = True


bpy.app.handlers.render_complete.append(on_done)
bpy.app.handlers.render_cancel.append(on_done)


def cycles_images(path, wall0):
    """Seconds after wall0 of the end of each display update in Cycles' log (glog: local time of
    day, microseconds)."""
    day = datetime.datetime.fromtimestamp(wall0)
    out = []
    with open(path, errors="replace") as f:
        for line in f:
            if "Average display update time" not in line:
                continue
            m = re.match(r"I\d{4} (\d\d):(\d\d):(\d\d)\.(\d{6})", line)
            if m:
                h, mi, s, us = (int(v) for v in m.groups())
                t = day.replace(hour=h, minute=mi, second=s, microsecond=us).timestamp()
                out.append(t - wall0)
    return out


def report(at):
    print(f"F12 in the window: {engine}{' ' + method if engine != 'CYCLES' else ''}, "
          f"{scene.render.resolution_x}x{scene.render.resolution_y}, {threads} threads, {seconds:g} s, "
          f"load average {os.getloadavg()[0]:.1f}")
    if not at:
        print("  no image reached Blender (Cycles: was it run with --debug-cycles --verbose 4?)")
        return
    gaps = [b - a for a, b in zip(at, at[1:])]
    gaps_sorted = sorted(gaps)
    print(f"  {len(at)} images: first at {at[0]:.2f} s" + (
        f", then every {gaps_sorted[len(gaps) // 2]:.2f} s (median; {min(gaps):.2f}-{max(gaps):.2f} s)" if gaps else ""))
    print("  images at " + " ".join(f"{t:.2f}" for t in at))


def step():
    if state["t0"] is None:
        if engine == 'CYCLES':  # Cycles' log to a file while it renders
            log = tempfile.NamedTemporaryFile(prefix="f12_cycles_", suffix=".log", delete=False)
            sys.stderr.flush()
            state["saved_fd"] = os.dup(2)
            os.dup2(log.fileno(), 2)
            state["log"] = log.name
        win = bpy.context.window_manager.windows[0]
        area = max(win.screen.areas, key=lambda a: a.width * a.height)
        state["t0"], state["wall0"] = time.perf_counter(), time.time()
        with bpy.context.temp_override(window=win, area=area, screen=win.screen):
            bpy.ops.render.render('INVOKE_DEFAULT')
        return 0.1
    if not state["done"] and time.perf_counter() - state["t0"] < seconds + 60:
        return 0.1
    if state["saved_fd"] is not None:
        sys.stderr.flush()
        os.dup2(state["saved_fd"], 2)
        at = cycles_images(state["log"], state["wall0"])
        if "--keep-log" in args:
            print(f"Cycles' log: {state['log']}")
        else:
            os.unlink(state["log"])
    else:
        at = [t - state["t0"] for t in images]
    report(at)
    sys.stdout.flush()
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(step, first_interval=2.0)  # once the window is up
