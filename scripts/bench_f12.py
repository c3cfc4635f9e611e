"""F12 to the first pass on screen, in real Blender, split into its phases.

    blender -b --factory-startup --python scripts/json_to_blend.py -- scenes/cornell-dense.json /tmp/cd.blend
    blender -b --factory-startup /tmp/cd.blend --python scripts/bench_f12.py [-- --method pt --threads 2 --repeats 3]
    blender -b --factory-startup /tmp/cd.blend --python scripts/bench_f12.py -- --seconds 12   # the refresh table
        [--size 1920x1080] [--whole-passes: never pause a pass for an image, as before passes could]

(--factory-startup: an addon installed in Blender's user folder would be loaded instead of this
checkout's.)

Renders the file's scene with gradphoton (bpy.ops.render.render, what F12 runs) stopping after
one pass, and times, from the operator's call: the depsgraph export to numpy arrays, the native
build (SceneBuilder: world-space copy, Embree BVH), the native session (the integrator's set-up),
the first pass, its develop + copy into the render result, and the end of the first
update_result (the image on screen). Each phase is timed by wrapping the addon's own functions,
so the script measures the addon as it is. Background mode: Blender's window drawing is not
included (the UI redraws the image editor after update_result).

With --seconds S it renders for S seconds instead (the Time stop rule) and prints when each image
reached Blender (the end of each develop + copy, which update_result follows at once), from the
operator's call: the first image and the intervals between the next ones, what a user watching
the render window sees refresh.
"""
import os
import sys
import time

import numpy as np

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import addon_utils  # noqa: E402
from f12_images import mark_images  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def arg(name, default, kind=str):
    return kind(args[args.index(name) + 1]) if name in args else default


method = arg("--method", "pt")
threads = arg("--threads", 2, int)
repeats = arg("--repeats", 3, int)
seconds = arg("--seconds", 0.0, float)
size = arg("--size", "")  # WxH: the scene's resolution for this run (e.g. 1920x1080)
whole_passes = "--whole-passes" in args  # passes never paused for an image: the behaviour before they could be

addon_utils.enable("gradphoton", default_set=False)
from gradphoton import export, session  # noqa: E402

marks = {}  # phase -> (wall start, wall end, cpu seconds of the whole process), this render's first


def timed(name, fn):
    def wrapper(*a, **kw):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            return fn(*a, **kw)
        finally:
            marks.setdefault(name, (t0, time.perf_counter(), time.process_time() - c0))
    return wrapper


export.export_scene = timed("export", export.export_scene)
session.export.export_scene = export.export_scene  # session.py reads it through its module
export.ExportedScene.build = timed("build", export.ExportedScene.build)
_iterate = session.RenderSession._iterate_cancellable
if whole_passes:
    def _iterate(self, seconds=0.0, _inner=_iterate):
        return _inner(self, 0.0)
session.RenderSession._iterate_cancellable = timed("first pass", _iterate)
# Wall time at the end of every develop + copy (an image sent to Blender).
images = mark_images(session, lambda write: timed("develop + copy", write))

scene = bpy.context.scene
scene.render.engine = 'GRADPHOTON'
if size:
    scene.render.resolution_x, scene.render.resolution_y = (int(v) for v in size.split("x"))
    scene.render.resolution_percentage = 100
settings = scene.gradphoton
settings.method = method
settings.stop_rule = 'TIME' if seconds > 0 else 'PASSES'
settings.passes = 1
settings.time_limit = max(seconds, 0.01)
if hasattr(settings, "threads"):
    settings.threads = threads
scene.render.threads_mode = 'FIXED'
scene.render.threads = threads
scene.render.use_persistent_data = False

print(f"gradphoton F12: {bpy.data.filepath or 'unsaved scene'}, {scene.render.resolution_x}x"
      f"{scene.render.resolution_y} at {scene.render.resolution_percentage}%, method {method}, "
      f"threads {threads}, load average {os.getloadavg()[0]:.1f}")
# What runs between the timed phases, by the phase it leads to.
GAPS = {"export": "Blender before the export (render set-up, depsgraph)", "first pass":
        "session set-up (native Session, begin_result)", "build": "between export and build"}
totals = []
for r in range(repeats):
    marks.clear()
    images.clear()
    t0, c0 = time.perf_counter(), time.process_time()
    bpy.ops.render.render()
    total, cpu = time.perf_counter() - t0, time.process_time() - c0
    if seconds > 0:
        at = [t - t0 for t in images]
        gaps = np.diff(at)
        passes = session.LAST.updates[-1][1] if session.LAST and session.LAST.updates else 0
        print(f"run {r + 1}: {len(at)} images in {total:.1f} s ({passes} passes): first at {at[0]:.2f} s, "
              f"then every {np.median(gaps):.2f} s (median; {gaps.min():.2f}-{gaps.max():.2f} s)" if len(at) > 1 else
              f"run {r + 1}: one image at {at[0]:.2f} s")
        print("  images at " + " ".join(f"{t:.2f}" for t in at))
        totals.append(at[0])
        continue
    first_on_screen = marks["develop + copy"][1] - t0  # update_result follows _write at once
    print(f"run {r + 1}: first pass on screen {1e3 * first_on_screen:.0f} ms "
          f"(operator {1e3 * total:.0f} ms wall, {1e3 * cpu:.0f} ms CPU)")
    prev = t0
    for name, (s, e, c) in sorted(marks.items(), key=lambda kv: kv[1][0]):
        if s - prev > 0.005:
            print(f"  {GAPS.get(name, 'untimed'):<48} {1e3 * (s - prev):6.0f} ms")
        print(f"  {name:<48} {1e3 * (e - s):6.0f} ms  (CPU {1e3 * c:.0f} ms)")
        prev = e
    totals.append(first_on_screen)
if seconds > 0:
    print(f"F12 to the first image: best {min(totals):.2f} s over {repeats} renders; load average "
          f"{os.getloadavg()[0]:.1f} at the end")
    sys.exit(0)
print(f"F12 to the first pass on screen: best {1e3 * min(totals):.0f} ms, median "
      f"{1e3 * sorted(totals)[len(totals) // 2]:.0f} ms over {repeats} renders; load average "
      f"{os.getloadavg()[0]:.1f} at the end")
