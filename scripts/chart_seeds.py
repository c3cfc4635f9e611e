#!/usr/bin/python3
"""Median relMSE over several convergence.py CSVs (one per seed) per (scene, method, seconds),
drawn as one log-log chart per scene with the spread (min..max) as error bars.

    scripts/chart_seeds.py docs/convergence/msppm3/msppm3-x0.375-seed*.csv --out docs/convergence/msppm3/cornell-glass-seeds.png
"""
import argparse
import csv
import statistics
from collections import defaultdict
from pathlib import Path


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csvs", nargs="+", type=Path)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--methods", nargs="*", help="only these methods, in this order")
    ap.add_argument("--column", default="relmse",
                    help="relmse, or relmse_excess for runs with convergence.py --ref-split")
    args = ap.parse_args()
    runs = defaultdict(list)
    for path in args.csvs:
        with open(path) as f:
            for r in csv.DictReader(f):
                if r["scene"] == args.scene:
                    runs[(r["method"], float(r["seconds"]))].append(float(r[args.column]))
    methods = args.methods or sorted({m for m, _ in runs})
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 4))
    for method in methods:
        ts = sorted(t for m, t in runs if m == method)
        if not ts:
            continue
        med = [statistics.median(runs[(method, t)]) for t in ts]
        lo = [m - min(runs[(method, t)]) for m, t in zip(med, ts)]
        hi = [max(runs[(method, t)]) - m for m, t in zip(med, ts)]
        n = len(runs[(method, ts[0])])
        ax.errorbar(ts, med, yerr=[lo, hi], marker="o", capsize=3, label=f"{method} ({n} runs)")
        print(args.scene, method, " ".join(f"{t:g}s {m:.4g}" for t, m in zip(ts, med)))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("render time (s)")
    label = "relMSE less reference noise" if args.column == "relmse_excess" else "relMSE"
    ax.set_ylabel(f"{label} (median, min..max)")
    ax.set_title(args.scene)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
