#!/usr/bin/python3
"""Scores saved checkpoints against several split references, to see how far a conclusion
depends on the reference.

A reference rendered by a method shares that method's bias: an SPPM reference with SPPM's own
radius rule (two pixels, alpha 0.7) blurs every edge the way SPPM at a long budget does, so
SPPM's blur is not counted as error and a sharper method's sharpness is (docs/gradient.md, "A
reference that shares SPPM's bias"). A fixed radius a fraction of a pixel wide,
`sppm:photons=200000,footprint=0.15,alpha=0.99999`, has almost no blur and much more noise; the
split references' noise term (convergence.py, SplitReference) removes the noise in expectation.

    scripts/rescore.py --snapshots DIR --scene torus-glass --scale 0.25 --methods sppm gpm \
        --checkpoints 8,16,32,64,128,300 \
        --reference "sppm rule" 'build/references/torus-glass-x0.25-sppm_photons_200000-1500p-seed100000[34].exr' \
        --reference "fixed 0.15 px" 'build/references/torus-glass-x0.25-sppm_photons_200000_footprint_0.15_alpha_0.99999-1000p-seed100000[34].exr' \
        --csv out.csv --chart out.png

DIR holds convergence.py's snapshots, SCENE-METHOD.Ts.exr (copied from build/convergence before
the next run overwrites them). Each --reference is a label and a glob matching exactly two EXRs.
"""
import argparse
import csv
import glob
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from convergence import SplitReference, file_tag, read_combined  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--snapshots", type=pathlib.Path, required=True)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--scale", type=float, required=True, help="only for the chart's title")
    ap.add_argument("--methods", nargs="+", required=True)
    ap.add_argument("--checkpoints", required=True, help="seconds, comma separated")
    ap.add_argument("--reference", nargs=2, action="append", required=True, metavar=("LABEL", "GLOB"))
    ap.add_argument("--csv", type=pathlib.Path)
    ap.add_argument("--chart", type=pathlib.Path)
    args = ap.parse_args()

    checkpoints = [float(s) for s in args.checkpoints.split(",")]
    rows = []
    excess = {}  # (reference label, method, seconds) -> relMSE less the references' noise
    for label, pattern in args.reference:
        paths = sorted(glob.glob(pattern))
        if len(paths) != 2:
            sys.exit(f"--reference {label}: {pattern} matches {len(paths)} files, not 2")
        split = SplitReference.from_files(*paths)
        for method in args.methods:
            for t in checkpoints:
                snap = args.snapshots / f"{args.scene}-{file_tag(method)}.{t:g}s.exr"
                if not snap.exists():
                    sys.exit(f"missing snapshot {snap}")
                relmse, excess[label, method, t] = split.errors(read_combined(snap))
                rows.append({"scene": args.scene, "reference": label, "method": method, "seconds": t,
                             "relmse": relmse, "relmse_excess": excess[label, method, t]})
        base = args.methods[0]
        for method in args.methods[1:]:
            ratios = [excess[label, method, t] / excess[label, base, t] for t in checkpoints]
            print(f"{label:16s} {method} / {base}: " + " / ".join(f"{x:.2f}" for x in ratios))

    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    if args.chart:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, len(args.reference), figsize=(5 * len(args.reference), 4), sharey=True,
                                 squeeze=False)
        for ax, (label, _) in zip(axes[0], args.reference):
            for method in args.methods:
                pts = [(t, excess[label, method, t]) for t in checkpoints if excess[label, method, t] > 0]
                ax.loglog(*zip(*pts), marker="o", label=method)
            ax.set_title(f"{args.scene} x{args.scale:g}, reference: {label}")
            ax.set_xlabel("render time (s)")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend()
        axes[0][0].set_ylabel("relMSE less reference noise")
        fig.tight_layout()
        fig.savefig(args.chart, dpi=100)


if __name__ == "__main__":
    main()
