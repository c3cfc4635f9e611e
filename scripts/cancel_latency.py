#!/usr/bin/python3
"""How long each method takes to stop after a cancel (docs/reliability.md, "Cancellation").

    PYTHONPATH=build/python scripts/cancel_latency.py [--size 1920x1080] [--trials 3] [--methods pt gpm ...]

Renders scenes/cornell-glass.json at 1080p with each method's default parameters (photon
methods: their default photon count per pass, or --photons) in a background thread, as Blender's
render thread does, cancels at a random moment after the first pass has started (as Esc and the
CLI's Ctrl-C do: ProgressSink::cancel_flag) and measures how long run() takes to return. Prints a
Markdown table; exit status 1 when a method's worst trial exceeds --limit seconds (default 0.5).
"""
import argparse
import json
import pathlib
import random
import sys
import threading
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "build" / "python"))
from gradphoton import _native  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "cornell-glass.json"))
    ap.add_argument("--methods", nargs="*", default=_native.methods())
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--trials", type=int, default=3)
    ap.add_argument("--delay", type=float, default=3.0, help="cancel at a uniform random time in [0.2, delay] s")
    ap.add_argument("--limit", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--photons", type=int, default=0, help="photons per pass for the photon methods (default: theirs)")
    args = ap.parse_args()
    width, height = map(int, args.size.split("x"))
    text = json.loads(pathlib.Path(args.scene).read_text())
    text["camera"]["width"], text["camera"]["height"] = width, height
    scene = _native.load_scene_json(json.dumps(text), str(pathlib.Path(args.scene).parent))
    rng = random.Random(args.seed)
    print(f"{width}x{height}, default parameters" + (f" but {args.photons} photons per pass" if args.photons else "") +
          f", {args.trials} cancels per method at random times in "
          f"[0.2, {args.delay}] s\n")
    print("| method | passes done at cancel | latency median (s) | latency max (s) |")
    print("| --- | ---: | ---: | ---: |")
    failed = False
    for method in args.methods:
        latencies, passes = [], []
        for trial in range(args.trials):
            params = {"seed": trial + 1}
            if args.photons and "photons" not in _native.method_info(method, {"photons": args.photons})["unused"]:
                params["photons"] = args.photons
            session = _native.Session(scene, method, params)
            worker = threading.Thread(target=session.run, kwargs={"seconds": 3600})
            worker.start()
            time.sleep(rng.uniform(0.2, args.delay))
            t0 = time.perf_counter()
            session.cancel()
            worker.join()
            latencies.append(time.perf_counter() - t0)
            passes.append(session.stats["passes"])
        latencies.sort()
        worst = latencies[-1]
        failed |= worst > args.limit
        print(f"| {method} | {'/'.join(map(str, passes))} | {latencies[len(latencies) // 2]:.3f} | {worst:.3f} |"
              + (" SLOW" if worst > args.limit else ""), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
