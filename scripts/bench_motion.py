#!/usr/bin/python3
"""Motion blur's cost in the accelerator: a 1 M-triangle grid built static and deforming with 3
steps (motion_positions), through SceneBuilder: finalize() time (BVH build and light setup) and
the process's resident memory growth. docs/benchmarks.md has the figures.

    scripts/bench_motion.py [--steps 3] [--side 708]
"""
import argparse, json, os, resource, sys, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "build", "python"))
import numpy as np  # noqa: E402
from gradphoton import _native  # noqa: E402


def rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def grid(side):
    xs, ys = np.meshgrid(np.linspace(-1, 1, side + 1, dtype=np.float32), np.linspace(-1, 1, side + 1, dtype=np.float32))
    pos = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size, np.float32)], 1)
    i = np.arange(side * (side + 1)).reshape(side, side + 1)[:, :side].ravel().astype(np.uint32)
    a, b, c, d = i, i + 1, i + side + 1, i + side + 2
    idx = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]).astype(np.uint32)
    return np.ascontiguousarray(pos), np.ascontiguousarray(idx)


def build(pos, idx, steps):
    desc = {"camera": {"position": [0, -3, 1], "look_at": [0, 0, 0], "width": 64, "height": 64},
            "materials": {"grey": {"type": "diffuse", "color": 0.5}},
            "lights": [{"type": "point", "position": [0, 0, 2], "power": 100}]}
    b = _native.SceneBuilder("bench")
    b.set_description(json.dumps(desc))
    mp = None
    if steps:
        mp = np.ascontiguousarray(np.stack([pos + np.array([0, 0, 0.1 * s], np.float32) for s in range(steps)]))
    before = rss_mb()
    t0 = time.perf_counter()
    b.add_mesh("grid", pos, idx, ["grey"], motion_positions=mp)
    scene = b.finalize()
    return time.perf_counter() - t0, rss_mb() - before, scene


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--side", type=int, default=708)  # 2 * 708^2 = 1.0 M triangles
    a = ap.parse_args()
    pos, idx = grid(a.side)
    print(f"triangles {len(idx):,}  vertices {len(pos):,}  load average {os.getloadavg()[0]:.2f}")
    for steps in (0, a.steps):
        t, mb, scene = build(pos, idx, steps)
        print(f"{'static' if not steps else f'deforming, {steps} steps':22s} add_mesh + finalize {t:6.2f} s   "
              f"resident memory +{mb:7.1f} MB")
        del scene
