#!/usr/bin/python3
"""Error against time for every (scene, method): the chart gradphoton is judged by.

For each scene, renders a reference (a long run, path traced unless --ref-method says
otherwise, with a fixed seed and pass count, cached under build/references/), then runs every
method with --checkpoints, diffs each snapshot against the reference with `gradphoton diff`
(relMSE of the gradient-domain photon paper), writes a CSV and draws one log-log chart per
scene with all its methods.

    scripts/convergence.py --scenes cornell-box torus-glass --methods pt \
        --checkpoints 1,2,4,8,16 --ref-passes 4096 --scale 0.5
    scripts/convergence.py --methods pt sppm --scenes torus-glass cornell-glass --scale 0.375

Any name make_integrator knows works in --methods (pt, ppm, sppm, gpt, ...), with its defaults
or with parameters after a colon: `gpt:recon=l1`, `sppm:photons=1000000,alpha=0.9` (passed as
--param; the whole spec is the label on the chart). --csv names the table under --out (default convergence.csv), so runs for different documents
do not overwrite each other:

    scripts/convergence.py --scenes door-ajar --methods pt sppm sppm-adaptive --scale 0.5 \
        --checkpoints 2,4,8,16,32 --ref-passes 8192 --csv adaptive.csv

--ref-files A B scores against two EXRs rendered elsewhere (a reference too long to render here,
its two halves with different seeds), as --ref-split does:

    scripts/convergence.py --scenes volumetric-caustic --scale 1 --methods pt sppm msppm \
        --checkpoints 5,10,20,40,60 --ref-files /work/refs/volumetric-caustic-ref-100000[34].exr

A reference rendered by `sppm` with its own radius rule shares SPPM's blur of edges, which
can favour SPPM at long budgets; `--ref-method sppm:photons=200000,footprint=0.15,alpha=0.99999`
(a fixed radius of 0.15 pixel) has almost none, at more noise that --ref-split removes in
expectation (docs/gradient.md, "A reference that shares SPPM's bias"; scripts/rescore.py scores
saved snapshots against several references).

--side-by-side runs a scene's methods at the same time, each on nproc / (number of methods)
threads (at least one), so that whatever else loads the machine slows them alike: on a shared
or noisy machine their equal-time ratios stay fair, where one-after-another runs do not.
"""
import argparse
import csv
import json
import os
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
CLI = ROOT / "build" / "gradphoton"


def run(cmd):
    print("+", " ".join(str(c) for c in cmd), file=sys.stderr)
    return subprocess.run([str(c) for c in cmd], check=True, capture_output=True, text=True).stdout


def size_args(scene, args):
    """--width/--height scaled from the scene's own camera, keeping its aspect ratio."""
    cam = json.loads((ROOT / "scenes" / f"{scene}.json").read_text()).get("camera", {})
    w, h = cam.get("width", 256), cam.get("height", 256)
    return ["--width", max(1, round(w * args.scale)), "--height", max(1, round(h * args.scale))]


def reference(scene, args, seed=None):
    """Long fixed-seed path-traced render, cached by scene, size, pass count and seed."""
    seed = args.ref_seed if seed is None else seed
    ref_dir = ROOT / "build" / "references"
    ref_dir.mkdir(parents=True, exist_ok=True)
    tag = f"{scene}-x{args.scale:g}-{file_tag(args.ref_method)}-{args.ref_passes}p-seed{seed}"
    path = ref_dir / f"{tag}.exr"
    scene_file = ROOT / "scenes" / f"{scene}.json"
    if not path.exists() or path.stat().st_mtime < scene_file.stat().st_mtime:
        run([CLI, "render", scene_file, *method_args(args.ref_method), "--passes", args.ref_passes,
             "--seed", seed, "-o", path, *size_args(scene, args)])
    return path


class SplitReference:
    """Two independent references (seeds s and s + 1); the reference is their mean.

    A noisy reference adds its own error to every method's: for an image x independent of the
    references, E[(x - r)^2] = E[(x - t)^2] + Var(r) per pixel (t the true value), and with two
    independent halves r_a, r_b of r = (r_a + r_b) / 2, (r_a - r_b)^2 / 4 is an unbiased
    estimate of Var(r). relMSE minus that term, with relMSE's own normalisation (io/metrics.cpp:
    squared error / (r^2 + 0.001), averaged over pixels and channels), estimates the error
    against the truth, and stays meaningful where the method's error is near the reference's
    (the caustics path tracing resolves slowly). It is an estimate: it can come out negative
    for a method far below the reference's noise.
    """

    def __init__(self, a, b):
        """a, b: the two references' combined passes (numpy arrays of one shape)."""
        self.ref = 0.5 * (a + b)
        self.norm = self.ref ** 2 + 0.001
        self.noise = (a - b) ** 2 / 4.0

    @classmethod
    def from_files(cls, path_a, path_b):
        return cls(read_combined(path_a), read_combined(path_b))

    def errors(self, x):
        """(relMSE against the mean reference, the same less the reference's noise) of image x."""
        raw = (x - self.ref) ** 2 / self.norm
        return float(raw.mean()), float((raw - self.noise / self.norm).mean())

    def trimmed(self, x, share=0.001):
        """The second of errors(x) without the `share` pixels of largest raw error (their terms
        left out, the mean still over all pixels): whether a difference is more than a few
        pixels that a caustic's focus decides by which photons landed there."""
        import numpy as np
        raw = ((x - self.ref) ** 2 / self.norm).reshape(-1, x.shape[-1]).mean(axis=1)
        excess = ((x - self.ref) ** 2 - self.noise) / self.norm
        excess = excess.reshape(-1, x.shape[-1]).mean(axis=1)
        keep = np.argsort(raw)[: int(raw.size * (1 - share))]
        return float(excess[keep].sum() / raw.size)


def read_combined(path):
    """The combined pass of an EXR, float64, via the native module's reader."""
    import numpy as np
    sys.path.insert(0, str(ROOT / "build" / "python"))
    from gradphoton import _native as native
    return native.read_exr(str(path))["combined"].astype(np.float64)


def method_args(spec):
    """'gpt:recon=l1,lambda=0.2' -> ['--method', 'gpt', '--param', 'recon=l1', '--param', 'lambda=0.2']."""
    name, _, params = spec.partition(":")
    out = ["--method", name]
    for kv in filter(None, params.split(",")):
        out += ["--param", kv]
    return out


def file_tag(spec):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", spec)


def rel_mse(image, ref):
    out = run([CLI, "diff", image, ref])
    return float(re.search(r"relMSE\s+(\S+)", out).group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-glass", "torus-glass"])
    ap.add_argument("--methods", nargs="+", default=["pt"])
    ap.add_argument("--checkpoints", default="1,2,4,8,16,32", help="seconds, comma separated")
    ap.add_argument("--ref-passes", type=int, default=4096)
    ap.add_argument("--ref-method", default="pt",
                    help="method of the reference (pt; a long sppm run is cleaner on SDS scenes)")
    ap.add_argument("--ref-seed", type=int, default=1000003)
    ap.add_argument("--ref-split", action="store_true",
                    help="render a second reference with seed ref-seed + 1, diff against the mean of the two "
                         "and also report relMSE less the reference's own noise (column relmse_excess)")
    ap.add_argument("--ref-files", nargs=2, type=pathlib.Path, metavar=("A", "B"),
                    help="score against these two EXRs (halves of one reference rendered with different seeds, "
                         "at the runs' size) as --ref-split does, instead of rendering a reference; one scene only")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scale", type=float, default=0.5, help="image size relative to the scene's camera")
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "convergence")
    ap.add_argument("--csv", default="convergence.csv", help="name of the table written under --out")
    ap.add_argument("--side-by-side", action="store_true",
                    help="run a scene's methods concurrently, the cores split between them")
    ap.add_argument("--cli", type=pathlib.Path, default=CLI,
                    help="gradphoton binary of the methods' runs (another build's, to compare before/after); "
                         "references always come from this checkout's build")
    args = ap.parse_args()
    if args.ref_files and len(args.scenes) != 1:
        ap.error("--ref-files goes with one scene")
    for path in args.ref_files or []:
        if not path.is_file():
            ap.error(f"--ref-files: {path} does not exist")
    args.ref_split = args.ref_split or bool(args.ref_files)

    checkpoints = [float(t) for t in args.checkpoints.split(",")]
    work = ROOT / "build" / "convergence"
    work.mkdir(parents=True, exist_ok=True)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for scene in args.scenes:
        if args.ref_files:
            ref, split = args.ref_files[0], SplitReference.from_files(*args.ref_files)
        else:
            ref = reference(scene, args)
            split = SplitReference.from_files(ref, reference(scene, args, args.ref_seed + 1)) if args.ref_split else None
        cmds = [[args.cli, "render", ROOT / "scenes" / f"{scene}.json", *method_args(method),
                 "--time", max(checkpoints), "--checkpoints", ",".join(f"{t:g}" for t in checkpoints),
                 "--seed", args.seed, "-o", work / f"{scene}-{file_tag(method)}.exr", *size_args(scene, args)]
                for method in args.methods]
        if args.side_by_side:
            threads = max(1, (os.cpu_count() or 1) // len(cmds))
            procs = []
            for cmd in cmds:
                cmd += ["--threads", threads]
                print("+", " ".join(str(c) for c in cmd), file=sys.stderr)
                procs.append(subprocess.Popen([str(c) for c in cmd], stdout=subprocess.DEVNULL))
            if any([p.wait() != 0 for p in procs]):  # a list: wait for every one
                sys.exit(f"a render of {scene} failed")
        else:
            for cmd in cmds:
                run(cmd)
        for method in args.methods:
            for t in checkpoints:
                snap = work / f"{scene}-{file_tag(method)}.{t:g}s.exr"
                if not snap.exists():
                    continue
                row = {"scene": scene, "method": method, "seconds": t}
                if split:
                    row["relmse"], row["relmse_excess"] = split.errors(read_combined(snap))
                else:
                    row["relmse"] = rel_mse(snap, ref)
                rows.append(row)
                extra = f"  less reference noise {row['relmse_excess']:.5g}" if split else ""
                print(f"{scene:14s} {method:14s} {t:8g} s  relMSE {row['relmse']:.5g}{extra}")

    csv_path = args.out / args.csv
    with open(csv_path, "w", newline="") as f:
        fields = ["scene", "method", "seconds", "relmse"] + (["relmse_excess"] if args.ref_split else [])
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for scene in args.scenes:
        fig, ax = plt.subplots(figsize=(5, 4))
        for method in args.methods:
            key = "relmse_excess" if args.ref_split else "relmse"
            pts = [(r["seconds"], r[key]) for r in rows if r["scene"] == scene and r["method"] == method and r[key] > 0]
            if pts:
                ax.loglog(*zip(*pts), marker="o", label=method)
        ax.set_xlabel("render time (s)")
        ax.set_ylabel("relMSE less reference noise" if args.ref_split else "relMSE")
        ax.set_title(scene)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.out / f"{scene}.png", dpi=100)
        plt.close(fig)
    print(f"wrote {csv_path} and one chart per scene in {args.out}")


if __name__ == "__main__":
    main()
