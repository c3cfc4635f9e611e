#!/usr/bin/python3
"""What the error estimate's boundary probes cost (docs/benchmarks.md): SPPM passes with
error_bound=boundary (probes: ProgressivePhotonMapping::disc_shape) and error_bound=calibrated (none),
alternated in one process on one thread, so both see the same machine load; rays per pass and the
ratio of pass times.

    scripts/bench_boundary_probes.py --scene cornell-box --size 128 --photons 100000 --passes 4 --repeats 3
"""
import argparse
import json
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "build" / "python"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell-box")
    ap.add_argument("--size", type=int, default=128, help="image width and height")
    ap.add_argument("--photons", type=int, default=100000)
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    from gradphoton import _native as native

    j = json.loads((ROOT / "scenes" / f"{args.scene}.json").read_text())
    j["camera"]["width"] = j["camera"]["height"] = args.size
    scene = native.load_scene_json(json.dumps(j), str(ROOT / "scenes"))
    totals = {b: [0.0, 0.0] for b in ("boundary", "calibrated")}
    for _ in range(args.repeats):
        for bound in totals:
            s = native.Session(scene, "sppm", dict(photons=args.photons, threads=1, seed=1, error_bound=bound))
            s.set_aux_passes(False)
            s.run(passes=args.passes)
            totals[bound][0] += s.stats["rays"]
            totals[bound][1] += s.stats["seconds"]
    n = args.repeats * args.passes
    for bound, (rays, seconds) in totals.items():
        print(f"{bound:10s} rays per pass {rays / n:12.0f}  seconds per pass {seconds / n:.4f}")
    (rc, sc), (rt, st) = totals["boundary"], totals["calibrated"]
    print(f"boundary / calibrated: rays {rc / rt:.2f}, time {sc / st:.2f}")


if __name__ == "__main__":
    main()
