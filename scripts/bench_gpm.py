#!/usr/bin/python3
"""GPM's cost per pass beside SPPM's (the paper reports 1.5-3.5x), and what the manifold walk adds.

Runs sppm, gpm without the walk (manifold_iterations 0) and gpm interleaved, `--repeats` times
each, same seed, size and photons, and prints the median seconds per pass of each, the ratios,
and gpm's split of a pass (eye / trace / lookup+shifts / update seconds).

  scripts/bench_gpm.py [--scenes cornell-box cornell-glass torus-glass] [--size 128] [--photons 100000]
                       [--passes 4] [--repeats 3]
"""
import argparse
import pathlib
import re
import statistics
import subprocess
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
CONFIGS = [("sppm", ["--method", "sppm"]),
           ("gpm, no walk", ["--method", "gpm", "--param", "manifold_iterations=0"]),
           ("gpm", ["--method", "gpm"])]


def run(cli, scene, args, opts, out):
    cmd = [str(cli), "render", str(ROOT / "scenes" / f"{scene}.json"), *args, "--width", str(opts.size),
           "--height", str(opts.size), "--passes", str(opts.passes), "--photons", str(opts.photons),
           "--seed", "1", "-o", out]
    text = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    stat = lambda key: float(re.search(rf"^{key}\s+([0-9.e+-]+)", text, re.M).group(1))
    split = {k: stat(f"{k} seconds") / opts.passes for k in ("eye", "trace", "lookup", "update")}
    return stat("seconds") / stat("passes"), split


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-glass", "torus-glass"])
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--photons", type=int, default=100000)
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cli", default=str(ROOT / "build" / "gradphoton"))
    opts = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = str(pathlib.Path(tmp) / "bench.exr")
        print(f"{opts.size}x{opts.size}, {opts.photons} photons/pass, {opts.passes} passes, median of {opts.repeats}")
        print(f"{'scene':14} {'sppm s/pass':>11} {'no walk':>9} {'gpm':>9} {'no walk/sppm':>12} {'gpm/sppm':>9}"
              f"   gpm pass: eye / trace / lookup+shifts / update s")
        for scene in opts.scenes:
            times = {name: [] for name, _ in CONFIGS}
            splits = []
            for _ in range(opts.repeats):  # interleaved, so load drifts hit every method alike
                for name, args in CONFIGS:
                    t, split = run(opts.cli, scene, args, opts, out)
                    times[name].append(t)
                    if name == "gpm":
                        splits.append(split)
            med = {name: statistics.median(v) for name, v in times.items()}
            s = {k: statistics.median(x[k] for x in splits) for k in splits[0]}
            print(f"{scene:14} {med['sppm']:11.3f} {med['gpm, no walk']:9.3f} {med['gpm']:9.3f} "
                  f"{med['gpm, no walk'] / med['sppm']:12.2f} {med['gpm'] / med['sppm']:9.2f}"
                  f"   {s['eye']:.3f} / {s['trace']:.3f} / {s['lookup']:.3f} / {s['update']:.4f}")


if __name__ == "__main__":
    main()
