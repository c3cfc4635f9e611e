#!/usr/bin/python3
"""Equal-time comparison of photon-method variants, run side by side (docs/photon-mapping.md,
docs/adaptive-and-msppm.md).

Each variant is `label=method[:params]` or `label=method[:params]@path/to/gradphoton` (another
build's binary, for before/after comparisons). For every scene all variants render at the same
time, each on nproc / (number of variants) threads, with --checkpoints; every snapshot is
diffed against the mean of two independent references (convergence.py --ref-split) and
reported as relMSE less the references' own noise. Writes a CSV and one chart per scene.

    scripts/photon_compare.py --scenes cornell-glass glossy-caustics --scale 0.125 \\
        --variants gated=msppm@/tmp/gradphoton-gated ungated=msppm --checkpoints 4,8,16,32
"""
import argparse
import csv
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from convergence import CLI, SplitReference, file_tag, method_args, read_combined, reference, size_args  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", required=True)
    ap.add_argument("--variants", nargs="+", required=True, help="label=method[:params][@binary]")
    ap.add_argument("--checkpoints", default="4,8,16,32", help="seconds, comma separated")
    ap.add_argument("--ref-passes", type=int, default=4096)
    ap.add_argument("--ref-method", default="pt")
    ap.add_argument("--ref-seed", type=int, default=1000003)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scale", type=float, default=0.125)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "convergence")
    ap.add_argument("--csv", required=True, help="name of the table written under --out")
    args = ap.parse_args()
    checkpoints = [float(t) for t in args.checkpoints.split(",")]
    variants = []
    for v in args.variants:
        label, _, spec = v.partition("=")
        spec, _, binary = spec.partition("@")
        variants.append((label, spec, pathlib.Path(binary) if binary else CLI))
    work = ROOT / "build" / "photon-compare"
    work.mkdir(parents=True, exist_ok=True)
    args.out.mkdir(parents=True, exist_ok=True)
    threads = max(1, (os.cpu_count() or 1) // len(variants))
    rows = []
    for scene in args.scenes:
        split = SplitReference.from_files(reference(scene, args), reference(scene, args, args.ref_seed + 1))
        procs = []
        for label, spec, binary in variants:
            cmd = [binary, "render", ROOT / "scenes" / f"{scene}.json", *method_args(spec), "--time", max(checkpoints),
                   "--checkpoints", ",".join(f"{t:g}" for t in checkpoints), "--seed", args.seed, "--threads", threads,
                   "-o", work / f"{scene}-{file_tag(label)}.exr", *size_args(scene, args)]
            print("+", " ".join(str(c) for c in cmd), file=sys.stderr)
            procs.append(subprocess.Popen([str(c) for c in cmd], stdout=subprocess.DEVNULL))
        if any([p.wait() != 0 for p in procs]):
            sys.exit(f"a render of {scene} failed")
        for label, spec, _ in variants:
            for t in checkpoints:
                snap = work / f"{scene}-{file_tag(label)}.{t:g}s.exr"
                if not snap.exists():
                    continue
                raw, excess = split.errors(read_combined(snap))
                rows.append({"scene": scene, "variant": label, "spec": spec, "seconds": t, "relmse": raw,
                             "relmse_excess": excess})
                print(f"{scene:16s} {label:14s} {t:6g} s  relMSE {raw:.5g}  less reference noise {excess:.5g}")
    with open(args.out / args.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["scene", "variant", "spec", "seconds", "relmse", "relmse_excess"])
        w.writeheader()
        w.writerows(rows)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for scene in args.scenes:
        fig, ax = plt.subplots(figsize=(5, 4))
        for label, _, _ in variants:
            pts = [(r["seconds"], r["relmse_excess"]) for r in rows
                   if r["scene"] == scene and r["variant"] == label and r["relmse_excess"] > 0]
            if pts:
                ax.loglog(*zip(*pts), marker="o", label=label)
        ax.set_xlabel(f"render time (s, side by side, {threads} thread(s) each)")
        ax.set_ylabel("relMSE less reference noise")
        ax.set_title(scene)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.out / f"{pathlib.Path(args.csv).stem}-{scene}.png", dpi=100)
        plt.close(fig)
    print(f"wrote {args.out / args.csv} and one chart per scene")


if __name__ == "__main__":
    main()
