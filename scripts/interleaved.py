#!/usr/bin/python3
"""Equal-pass comparison with per-pass cost measured interleaved (docs/spectral.md).

On a shared, noisy machine wall-clock comparisons of methods run one after another mix the
methods' costs with the load of the moment. This script advances every method one pass at a
time in turn (round robin, one process), times each pass, and at the given pass counts reports
relMSE against the mean of two reference EXRs (as convergence.py --ref-split: raw and less the
reference's own noise), the mean seconds per pass, and the relMSE x time product at equal
passes (lower is better; equal-time relMSE ratios follow from it for 1/N convergence).

    scripts/interleaved.py scenes/pool.json --size 64x48 --methods spt-hero sgpt sgpt:tau=2.5 \\
        --refs build/references/pool-x0.4-spt-hero-8192p-seed1000003.exr \\
               build/references/pool-x0.4-spt-hero-8192p-seed1000004.exr --checkpoints 64,256,1024
"""
import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "build", "python"))
from gradphoton import _native  # noqa: E402


def parse_spec(spec):
    """'method:k=v,k=v' -> (method, {k: int, float, bool or str})."""
    name, _, rest = spec.partition(":")
    params = {}
    for kv in filter(None, rest.split(",")):
        k, v = kv.split("=")
        try:
            params[k] = int(v)
        except ValueError:
            try:
                params[k] = float(v)
            except ValueError:
                params[k] = {"true": True, "false": False}.get(v, v)
    return name, params


def load_scene_at(path, size):
    """The scene file with its camera resized to 'WxH' (empty or None: the file's size)."""
    j = json.load(open(path))
    if size:
        j["camera"]["width"], j["camera"]["height"] = (int(v) for v in size.lower().split("x"))
    return _native.load_scene_json(json.dumps(j), os.path.dirname(os.path.abspath(path)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--methods", nargs="+", required=True)
    ap.add_argument("--refs", nargs=2, required=True)
    ap.add_argument("--size", default="64x48")
    ap.add_argument("--checkpoints", default="64,256,1024")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--threads", type=int, default=0)
    a = ap.parse_args()
    scene = load_scene_at(a.scene, a.size)
    ra, rb = (_native.read_exr(p)["combined"].astype(np.float64) for p in a.refs)
    ref, noise = 0.5 * (ra + rb), (ra - rb) ** 2 / 4.0
    norm = ref ** 2 + 0.001
    checkpoints = [int(c) for c in a.checkpoints.split(",")]
    sessions, seconds = [], []
    for i, spec in enumerate(a.methods):
        name, params = parse_spec(spec)
        params.setdefault("seed", a.seed + i)
        if a.threads:
            params["threads"] = a.threads
        sessions.append(_native.Session(scene, name, params))
        seconds.append(0.0)
    print(f"{'method':28s} {'passes':>7s} {'relMSE':>9s} {'excess':>9s} {'s/pass':>8s} {'relMSE*s':>9s}")
    for n in range(1, checkpoints[-1] + 1):
        for i, s in enumerate(sessions):
            t0 = time.perf_counter()
            s.iterate()
            seconds[i] += time.perf_counter() - t0
        if n in checkpoints:
            for i, s in enumerate(sessions):
                img = s.develop()["combined"].astype(np.float64)
                raw = (img - ref) ** 2 / norm
                rel, exc = float(raw.mean()), float((raw - noise / norm).mean())
                print(f"{a.methods[i]:28s} {n:7d} {rel:9.4f} {exc:9.4f} {seconds[i] / n:8.4f} {rel * seconds[i]:9.3f}",
                      flush=True)
    for i, s in enumerate(sessions):
        shifts = {k: int(v) for k, v in s.stats.items() if "shift" in k or "pairs" in k}
        if shifts:
            print(f"{a.methods[i]}: {shifts}")


if __name__ == "__main__":
    main()
