"""Samples per second, Cycles vs gradphoton's path tracer, on the same .blend: a 256 x 256
Cornell box with a glass sphere, 2 threads, equal bounce limits, no denoising, no adaptive
sampling.

    blender -b --factory-startup --python scripts/bench_cycles.py [-- --bounces 8 --samples 64]

Each engine renders S/4 and S samples; samples/s = 256^2 (S - S/4) / (t_S - t_S/4), which
removes set-up costs (scene sync/export, BVH, kernel start) from the rate. Bounce limits: Cycles
max_bounces B (all kinds B) against gradphoton max_depth B + 1 (segments, camera ray included)."""
import os
import sys
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.join(ROOT, "tests", "blender"))
import addon_utils  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def arg(name, default):
    return int(args[args.index(name) + 1]) if name in args else default


BOUNCES, SAMPLES, SIZE = arg("--bounces", 8), arg("--samples", 64), arg("--size", 256)
addon_utils.enable("gradphoton", default_set=False)
import scenes  # noqa: E402

for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras):
    for item in list(coll):
        coll.remove(item)
scene = bpy.context.scene
scenes.cornell_glass(scene)
scene.render.resolution_x = scene.render.resolution_y = SIZE
scene.render.resolution_percentage = 100


def timed(samples, engine):
    if engine == "CYCLES":
        scenes.configure_cycles(scene, samples, BOUNCES)
    else:
        scene.render.engine = "GRADPHOTON"
        g = scene.gradphoton
        g.method, g.stop_rule, g.passes, g.threads, g.max_depth = "pt", 'PASSES', samples, 2, BOUNCES + 1
    t0 = time.perf_counter()
    bpy.ops.render.render()
    return time.perf_counter() - t0


rates = {}
for engine in ("CYCLES", "GRADPHOTON"):
    timed(4, engine)  # warm-up (Cycles kernel, caches)
    lo, hi = SAMPLES // 4, SAMPLES
    t_lo, t_hi = timed(lo, engine), timed(hi, engine)
    rates[engine] = SIZE * SIZE * (hi - lo) / max(1e-9, t_hi - t_lo)
    print(f"BENCH {engine:10s}: {lo} spp {t_lo:.2f} s, {hi} spp {t_hi:.2f} s -> {rates[engine] / 1e6:.3f} M samples/s")
print(f"BENCH {SIZE}x{SIZE} Cornell box + glass sphere, 2 threads, {BOUNCES} bounces: "
      f"Cycles {rates['CYCLES'] / 1e6:.3f} M samples/s, gradphoton pt {rates['GRADPHOTON'] / 1e6:.3f} M samples/s "
      f"(ratio {rates['GRADPHOTON'] / rates['CYCLES']:.2f})")
