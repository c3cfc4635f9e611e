#!/usr/bin/python3
"""How the error of merged independent-seed runs falls with the number of runs
(docs/distributed.md), with build/gradphoton render, merge and diff:

  for each N in --tasks: N runs of K passes (seeds 0..N-1, as Slurm array tasks) merged, and
  one run of N*K passes (seed 5000), both against a reference of --reference-passes passes
  (seed 1000000; same method unless --reference-method).

Unbiased methods: merged and single agree and relMSE x N stays flat. Photon methods: merged
keeps the bias of K passes, so it falls behind the single run as N grows.

  scripts/merge_study.py --scene scenes/cornell-glass.json --method sppm --passes 8 \
      --tasks 1,2,4,8 --reference-passes 512 -- --photons 20000
"""
import argparse
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
CLI = ROOT / "build" / "gradphoton"


def gradphoton(*args):
    p = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"gradphoton {' '.join(map(str, args))} failed:\n{p.stderr}")
    return p.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--method", default="pt")
    ap.add_argument("--passes", type=int, default=8, help="passes per run (K)")
    ap.add_argument("--tasks", default="1,2,4,8", help="numbers of runs N")
    ap.add_argument("--reference-passes", type=int, default=2048)
    ap.add_argument("--reference-method", help="default: --method")
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--height", type=int, default=64)
    ap.add_argument("--workdir", help="keep the images here (default: a temporary directory)")
    ap.add_argument("render_args", nargs="*", help="more gradphoton render arguments (after --)")
    a = ap.parse_args()
    tasks = [int(t) for t in a.tasks.split(",")]
    work = pathlib.Path(a.workdir or tempfile.mkdtemp(prefix="merge_study_"))
    work.mkdir(parents=True, exist_ok=True)

    def render(out, method, passes, seed):
        gradphoton("render", a.scene, "--method", method, "--passes", passes, "--seed", seed, "--width", a.width,
                   "--height", a.height, "-o", out, *a.render_args)
        return out

    def relmse(image):
        return float(re.search(r"relMSE\s+(\S+)", gradphoton("diff", image, ref)).group(1))

    ref = render(work / "reference.exr", a.reference_method or a.method, a.reference_passes, 1000000)
    runs = [render(work / f"run_{i}.exr", a.method, a.passes, i) for i in range(max(tasks))]
    print(f"{a.scene}, {a.method}, {a.width}x{a.height}, K = {a.passes} passes per run, reference "
          f"{a.reference_method or a.method} {a.reference_passes} passes {' '.join(a.render_args)}".rstrip())
    print("| runs N | N x K merged: relMSE | relMSE x N | one run of N x K: relMSE | merged / single |")
    print("| --- | --- | --- | --- | --- |")
    for n in tasks:
        merged = work / f"merged_{n}.exr"
        if n == 1:
            merged = runs[0]
        else:
            gradphoton("merge", *runs[:n], "-o", merged)
        single = render(work / f"single_{n}.exr", a.method, n * a.passes, 5000)
        m, s = relmse(merged), relmse(single)
        print(f"| {n} | {m:.4g} | {m * n:.4g} | {s:.4g} | {m / s:.2f} |")
    print(f"(images in {work})")


if __name__ == "__main__":
    main()
