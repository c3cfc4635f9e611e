#!/usr/bin/env python3
"""A half-transparent leaf two ways (issue 30): Cycles' Mix Shader of a white Transparent BSDF
and a Diffuse BSDF (factor 0.5: paths pick the transparent closure by its weight, next-event
estimation lights the diffuse one at every hit, shadow rays pass filtered by 0.5) against the
coverage cut-out the exporter once wrote for it (`alpha` 0.5: the leaf is there for half of all
rays, shadow rays included). Both have the same expected image; this measures their error at
64 passes against a reference (the mean of both methods' long renders), and their time, on a
bright scene (sky and floor behind the leaf) and a dark one. pt, one thread, renders alternated.

    scripts/bench_leaf_mix.py [build-dir] [reference-passes] [seeds]
"""
import json
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

build = sys.argv[1] if len(sys.argv) > 1 else "build"
ref_passes = int(sys.argv[2]) if len(sys.argv) > 2 else 1024
seeds = int(sys.argv[3]) if len(sys.argv) > 3 else 4
sys.path.insert(0, os.path.join(build, "python"))
from gradphoton import _native as native  # noqa: E402

LEAVES = {"cutout": {"type": "diffuse", "color": [0.2, 0.6, 0.1], "alpha": 0.5},
          "mix": {"type": "mix", "a": "clear", "b": "green", "factor": 0.5}}
BACKDROPS = {"bright": (0.7, [0.3, 0.35, 0.45]), "dark": (0.05, [0.02, 0.02, 0.03])}


def scene(leaf, floor, sky):
    return {"camera": {"position": [0, -6, 3], "look_at": [0, 0, 0.8], "up": [0, 0, 1], "fov": 35,
                       "width": 64, "height": 64},
            "materials": {"floor": {"type": "diffuse", "color": floor},
                          "green": {"type": "diffuse", "color": [0.2, 0.6, 0.1]},
                          "clear": {"type": "transparent", "color": 1}, "leaf": leaf},
            "lights": [{"type": "sun", "direction": [0.3, 0.4, -1], "irradiance": [3, 3, 2.8]}],
            "environment": {"color": sky, "strength": 1},
            "objects": [{"type": "quad", "center": [0, 0, 0], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
                        {"type": "quad", "center": [0, 0, 1.2], "u": [1.5, 0, 0], "v": [0, 0.2, 1.2],
                         "material": "leaf"}]}


def render(path, passes, seed, out):
    log = subprocess.run([os.path.join(build, "gradphoton"), "render", path, "--passes", str(passes),
                          "--threads", "1", "--seed", str(seed), "-o", out],
                         check=True, capture_output=True, text=True).stdout
    return native.read_exr(out), float(re.search(r"^seconds\s+([\d.]+)", log, re.M).group(1))


with tempfile.TemporaryDirectory() as tmp:
    for name, (floor, sky) in BACKDROPS.items():
        paths = {}
        for kind, leaf in LEAVES.items():
            paths[kind] = os.path.join(tmp, f"{name}-{kind}.json")
            with open(paths[kind], "w") as f:
                json.dump(scene(leaf, floor, sky), f)
        refs = {k: render(p, ref_passes, 99, os.path.join(tmp, "ref.exr"))[0] for k, p in paths.items()}
        ref = 0.5 * sum(r["combined"][..., :3].astype(np.float64) for r in refs.values())
        alb = refs["mix"]["albedo"][..., :3]
        leaf_px = np.abs(alb[..., 1] - alb[..., 0]) > 0.05  # the leaf's blend of green and white
        err = {k: [] for k in LEAVES}
        secs = {k: [] for k in LEAVES}
        for seed in range(1, seeds + 1):
            for kind, p in paths.items():  # alternated, so that the machine's load weighs on both
                img, s = render(p, 64, seed, os.path.join(tmp, "run.exr"))
                x = img["combined"][..., :3].astype(np.float64)
                rel = ((x - ref) ** 2 / (ref ** 2 + 1e-2)).mean(-1)
                err[kind].append((rel.mean(), rel[leaf_px].mean()))
                secs[kind].append(s)
        means = ", ".join(f"{k} {r['combined'][..., :3].mean():.5f}" for k, r in refs.items())
        print(f"{name}: reference means {means}; {int(leaf_px.sum())} leaf pixels")
        for kind in LEAVES:
            e = np.mean(err[kind], 0)
            t = np.mean(secs[kind])
            print(f"  {kind:7s} relMSE {e[0]:.4g} (leaf pixels {e[1]:.4g}), {t:.3f} s for 64 passes, "
                  f"efficiency 1/(relMSE s) {1 / (e[0] * t):.4g}")
