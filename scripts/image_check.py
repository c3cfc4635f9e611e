#!/usr/bin/python3
"""Every method on every scene in scenes/ at a fixed seed and pass count, small: a fingerprint
of each pass (a hash of its floats and its mean) to check that a refactoring changed no image.

    scripts/image_check.py record out/images-before.json       # before the change
    scripts/image_check.py compare out/images-before.json      # after: bit for bit, or the means

compare prints, per method and scene, "same" (every pass bit for bit), "round-off" (some pass
differs but every mean agrees to 1e-5 relative) or "DIFFERENT", and exits 1 on any DIFFERENT.
"""
import argparse
import glob
import hashlib
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "build", "python"))
from gradphoton import _native  # noqa: E402


def fingerprints(args):
    out = {}
    scenes = sorted(glob.glob(os.path.join(ROOT, "scenes", "*.json")))
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            for method in _native.methods():
                key = f"{method} {os.path.basename(scene)}"
                exr = os.path.join(tmp, "o.exr")
                cmd = [os.path.join(ROOT, "build", "gradphoton"), "render", scene, "--method", method,
                       "--passes", str(args.passes), "--width", str(args.width), "--height", str(args.height),
                       "--seed", "7", "--threads", "2", "-o", exr]
                r = subprocess.run(cmd, capture_output=True, text=True)
                if r.returncode != 0:
                    out[key] = {"error": (r.stderr.strip().splitlines() or ["?"])[-1]}
                    print(key, "error:", out[key]["error"], flush=True)
                    continue
                passes = _native.read_exr(exr)
                out[key] = {name: {"hash": hashlib.sha1(a.tobytes()).hexdigest(),
                                   "mean": [float(a[..., c].mean()) for c in range(a.shape[2])]}
                            for name, a in sorted(passes.items())}
                print(key, " ".join(f"{n}={v['mean'][0]:.6g}" for n, v in out[key].items()), flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mode", choices=["record", "compare"])
    ap.add_argument("file")
    ap.add_argument("--passes", type=int, default=2)
    ap.add_argument("--width", type=int, default=48)
    ap.add_argument("--height", type=int, default=36)
    args = ap.parse_args()
    now = fingerprints(args)
    if args.mode == "record":
        os.makedirs(os.path.dirname(os.path.abspath(args.file)), exist_ok=True)
        with open(args.file, "w") as f:
            json.dump(now, f, indent=1, sort_keys=True)
        return 0
    with open(args.file) as f:
        before = json.load(f)
    bad = 0
    for key in sorted(set(before) | set(now)):
        a, b = before.get(key), now.get(key)
        if a is None or b is None:
            print(f"{key:40s} DIFFERENT (only {'after' if a is None else 'before'})")
            bad += 1
            continue
        failed = lambda r: isinstance(r.get("error"), str)  # noqa: E731 (a pass may be called "error")
        if failed(a) or failed(b):
            verdict = "same" if a == b else "DIFFERENT"
        elif not set(a) <= set(b):  # passes added later (the CLI's albedo, normal, depth) are not compared
            verdict = f"DIFFERENT (passes {sorted(a)} -> {sorted(b)})"
        elif all(a[p]["hash"] == b[p]["hash"] for p in a):
            verdict = "same"
        elif all(abs(x - y) <= 1e-5 * max(abs(x), abs(y)) + 1e-7 for p in a for x, y in zip(a[p]["mean"], b[p]["mean"])):
            verdict = "round-off (" + ", ".join(p for p in a if a[p]["hash"] != b[p]["hash"]) + ")"
        else:
            verdict = "DIFFERENT (" + ", ".join(f"{p} {a[p]['mean'][0]:.6g} -> {b[p]['mean'][0]:.6g}"
                                               for p in a if a[p]["hash"] != b[p]["hash"]) + ")"
        bad += verdict.startswith("DIFFERENT")
        print(f"{key:40s} {verdict}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
