#!/usr/bin/python3
"""Bias or heavy tail? A z-test of an image mean between two methods (docs/spectral.md).

Each pass of a progressive method is an independent estimate (per-pixel streams keyed by
seed, pixel and pass), so the per-pass image means of one run are i.i.d.: their average and
standard error give a z-test of the method's expected image mean. The per-pass values are
recovered from the cumulative developed images (k M_k - (k-1) M_{k-1}); sgpt's L2 reconstruction
is linear, so this holds for its `combined` too.

    scripts/mean_ztest.py scenes/pool.json --methods spt-hero sgpt --passes 2000 --size 64x48

Prints per method and pass: mean (luminance-free: mean of R, G, B), standard error, skewness
and the share of the total carried by the largest 1 % of passes; then z of each method
against the first. |z| > 4 is reported as a bias (fixed seeds, threshold stated).
"""
import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "build", "python"))
from gradphoton import _native  # noqa: E402
from interleaved import load_scene_at, parse_spec  # noqa: E402


def per_pass_means(scene, method, passes, seed, params, layer):
    s = _native.Session(scene, method, dict(seed=seed, **params))
    prev = 0.0
    out = np.empty((passes, 3))
    for k in range(1, passes + 1):
        s.iterate()
        img = s.develop()[layer].astype(np.float64)
        tot = img.reshape(-1, 3).mean(axis=0) * k
        out[k - 1] = tot - prev
        prev = tot
    return out


def summary(x):
    m = x.mean()
    se = x.std(ddof=1) / math.sqrt(len(x))
    d = x - m
    skew = (d**3).mean() / (d**2).mean() ** 1.5 if (d**2).mean() > 0 else 0.0
    top = np.sort(x)[::-1][: max(1, len(x) // 100)].sum() / x.sum() if x.sum() != 0 else 0.0
    return m, se, skew, top


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--methods", nargs="+", default=["spt-hero", "sgpt"])
    ap.add_argument("--passes", type=int, default=1000)
    ap.add_argument("--ref-passes", type=int, default=0, help="passes of the first method (default --passes)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--size", default="64x48")
    ap.add_argument("--layer", default="combined")
    ap.add_argument("--threshold", type=float, default=4.0)
    a = ap.parse_args()
    scene = load_scene_at(a.scene, a.size)
    results = []
    for i, spec in enumerate(a.methods):
        method, params = parse_spec(spec)
        layer = a.layer if method == "sgpt" else "combined"
        passes = a.ref_passes if (i == 0 and a.ref_passes) else a.passes
        x = per_pass_means(scene, method, passes, a.seed + i, params, layer)
        grey = x.mean(axis=1)
        results.append((spec, grey, x))
        m, se, skew, top = summary(grey)
        chans = " ".join(f"{c:.5f}" for c in x.mean(axis=0))
        print(f"{spec:28s} mean {m:.5f} ± {se:.5f} (RGB {chans})  skew {skew:6.1f}  top1% share {top:.3f}", flush=True)
    ref = results[0]
    for spec, grey, x in results[1:]:
        m0, se0, _, _ = summary(ref[1])
        m1, se1, _, _ = summary(grey)
        z = (m1 - m0) / math.hypot(se0, se1)
        verdict = "BIAS" if abs(z) > a.threshold else "consistent"
        print(f"{spec} vs {ref[0]}: ratio {m1 / m0:.4f}, z = {z:+.2f} -> {verdict} (|z| > {a.threshold})")
        for c in range(3):
            mc0, sc0, _, _ = summary(ref[2][:, c])
            mc1, sc1, _, _ = summary(x[:, c])
            print(f"   channel {c}: ratio {mc1 / mc0:.4f}, z = {(mc1 - mc0) / math.hypot(sc0, sc1):+.2f}")


if __name__ == "__main__":
    main()
