#!/usr/bin/env python3
"""Error at equal samples of `pt` with sampling_pattern sobol against independent (docs/benchmarks.md,
the Sobol pattern): relMSE = mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01), as
scripts/bench_hdri.py, against a long reference box-downsampled by an integer factor to the
render's size (a box pixel filter of one pixel in both, so a downsampled pixel is the mean of
its block). Sample counts do not depend on the machine's load; times are not measured here.

    PYTHONPATH=build/python python3 scripts/sampling_pattern_error.py SCENE.json REF.exr [REF2.exr ...] \\
        --width W --height H [--spp 64 256 1024] [--seeds 0] [--param name=value ...] [--out /tmp/spe]

Several references are averaged (the halves of a split reference)."""
import argparse
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "build", "python"))
from gradphoton import _native  # noqa: E402


def combined(path):
    return _native.read_exr(path)["combined"][..., :3].astype(np.float64)


def downsample(img, h, w):
    fy, fx = img.shape[0] // h, img.shape[1] // w
    assert fy * h == img.shape[0] and fx * w == img.shape[1] and fx == fy, "integer factor"
    return img.reshape(h, fy, w, fx, 3).mean(axis=(1, 3))


def rel_mse(x, ref):
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("reference", nargs="+")
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--height", type=int, required=True)
    ap.add_argument("--spp", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--param", action="append", default=[])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default="/tmp/sampling_pattern_error")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    ref = np.mean([downsample(combined(r), a.height, a.width) for r in a.reference], axis=0)
    print(f"reference mean {np.round(ref.reshape(-1, 3).mean(0), 5)}")
    for spp in a.spp:
        row = {}
        for pattern in ("independent", "sobol"):
            errs, means = [], []
            for seed in a.seeds:
                out = os.path.join(a.out, f"{pattern}-{spp}-{seed}.exr")
                cmd = [os.path.join(ROOT, "build", "gradphoton"), "render", a.scene, "--passes", str(spp),
                       "--width", str(a.width), "--height", str(a.height), "--threads", str(a.threads),
                       "--seed", str(seed), "--param", f"sampling_pattern={pattern}", "-o", out]
                for p in a.param:
                    cmd += ["--param", p]
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
                img = combined(out)
                errs.append(rel_mse(img, ref))
                means.append(img.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0))
            row[pattern] = float(np.mean(errs))
            print(f"{spp:6d} spp {pattern:12s} relMSE {row[pattern]:.6f}  mean / reference "
                  f"{np.round(np.mean(means, axis=0), 4)}", flush=True)
        print(f"{spp:6d} spp relMSE independent / sobol {row['independent'] / row['sobol']:.3f}", flush=True)


if __name__ == "__main__":
    main()
