#!/usr/bin/python3
"""Resident memory over many passes, per method (docs/reliability.md, "Long runs").

    PYTHONPATH=build/python nice -n 19 scripts/soak.py [--passes 1000] [--warmup 100] [--methods pt gpm ...]

Renders scenes/cornell-glass.json at a small resolution (--size, default 32x24) pass by pass,
each method in a process of its own, and reads the resident set (/proc/self/statm) after the
warm-up pass and at the end.
Photon methods trace --photons per pass (default 20000, not 1 M: what a pass allocates does not
depend on the count, and 1000 passes stay minutes). Prints a Markdown table; exit status 1 when
any method grows by more than --limit percent (default 1) after the warm-up, or renders NaN/Inf.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "build" / "python"))
from gradphoton import _native  # noqa: E402

PAGE = os.sysconf("SC_PAGE_SIZE")


def rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE / 2**20


def scene_at(path, width, height):
    text = json.loads(pathlib.Path(path).read_text())
    text["camera"]["width"], text["camera"]["height"] = width, height
    return _native.load_scene_json(json.dumps(text), str(pathlib.Path(path).parent))


def params_for(method, photons):
    params = {"seed": 1}
    if "photons" not in _native.method_info(method, {"photons": photons})["unused"]:
        params["photons"] = photons
    return params


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "cornell-glass.json"))
    ap.add_argument("--methods", nargs="*", default=_native.methods())
    ap.add_argument("--passes", type=int, default=1000)
    ap.add_argument("--warmup", type=int, default=100)
    ap.add_argument("--size", default="32x24")
    ap.add_argument("--photons", type=int, default=20000)
    ap.add_argument("--limit", type=float, default=1.0, help="allowed growth after warm-up, percent")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)  # one method, one row
    args = ap.parse_args()
    if not args.child:
        print(f"{args.passes} passes at {args.size}, {args.photons} photons per pass where a method traces "
              f"photons; resident memory of the process (one per method) after pass {args.warmup} and at the end\n")
        print("| method | RSS after warm-up (MB) | RSS at end (MB) | growth | invalid samples | seconds |")
        print("| --- | ---: | ---: | ---: | ---: | ---: |", flush=True)
        rest = [a for a in sys.argv[1:]]
        if "--methods" in rest:
            i = rest.index("--methods")
            j = i + 1
            while j < len(rest) and not rest[j].startswith("--"):
                j += 1
            del rest[i:j]
        codes = [subprocess.call([sys.executable, __file__, "--child", "--methods", m] + rest) for m in args.methods]
        return 1 if any(codes) else 0
    width, height = map(int, args.size.split("x"))
    scene = scene_at(args.scene, width, height)
    failed = False
    for method in args.methods:
        session = _native.Session(scene, method, params_for(method, args.photons))
        t0 = time.time()
        warm = None
        for p in range(args.passes):
            session.iterate()
            if p + 1 == args.warmup:
                warm = rss_mb()
        end = rss_mb()
        image = session.develop()["combined"]
        growth = 100.0 * (end - warm) / warm
        stats = session.stats
        finite = bool(np.isfinite(image).all())
        ok = growth < args.limit and finite
        failed |= not ok
        print(f"| {method} | {warm:.1f} | {end:.1f} | {growth:+.2f} % | {stats['invalid_samples']} | "
              f"{time.time() - t0:.0f} |" + ("" if ok else " FAIL" + ("" if finite else " (non-finite image)")),
              flush=True)
        del session
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
