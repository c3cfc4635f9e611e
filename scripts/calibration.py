#!/usr/bin/python3
"""Calibration of the SPPM error estimate (thesis ch. 6, the measure of its Figure 6.6).

For each scene and user confidence, renders SPPM for several pass counts and reports the share
of pixels whose estimated relative error bound (the `error` pass, eq. 6.13) is at least the
actual relative error against a long path-traced reference (`gradphoton diff --error-pass`).
Writes a Markdown table.

    scripts/calibration.py --scenes cornell-box cornell-glass --passes 4,16,64 --scale 0.1875
"""
import argparse
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from convergence import CLI, reference, run, size_args  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-glass"])
    ap.add_argument("--passes", default="4,16,64")
    ap.add_argument("--confidences", default="0.5,0.9")
    ap.add_argument("--photons", type=int, default=20000)
    ap.add_argument("--ref-passes", type=int, default=2048)
    ap.add_argument("--ref-method", default="pt", help="method of the reference (as in convergence.py)")
    ap.add_argument("--ref-seed", type=int, default=1000003)
    ap.add_argument("--scale", type=float, default=0.1875)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "error-calibration.md")
    args = ap.parse_args()
    work = ROOT / "build" / "calibration"
    work.mkdir(parents=True, exist_ok=True)
    passes = [int(p) for p in args.passes.split(",")]
    confidences = [float(c) for c in args.confidences.split(",")]
    rows = []
    for scene in args.scenes:
        ref = reference(scene, args)
        for conf in confidences:
            for n in passes:
                out = work / f"{scene}-c{conf:g}-{n}p.exr"
                log = run([CLI, "render", ROOT / "scenes" / f"{scene}.json", "--method", "sppm", "--passes", n,
                           "--photons", args.photons, "--confidence", conf, "--seed", 7, "-o", out,
                           *size_args(scene, args)])
                est = float(re.search(r"est\. error\s+(\S+)", log).group(1))
                d = run([CLI, "diff", out, ref, "--error-pass", "error"])
                cov = float(re.search(r"coverage\s+(\S+)", d).group(1))
                rel = float(re.search(r"relMSE\s+(\S+)", d).group(1))
                rows.append((scene, conf, n, cov, est, rel))
                print(f"{scene:14s} conf {conf:4.2f} passes {n:5d}  coverage {cov:.3f}  avg est {est:.4f}  relMSE {rel:.5f}")
    with open(args.out, "w") as f:
        f.write("# Calibration of the SPPM error estimate\n\n")
        f.write("Share of pixels whose estimated relative error bound (pass `error`, thesis eq. 6.13) is at\n"
                "least the actual relative error |L - L_ref| / L against a long path-traced reference: the\n"
                "measure of the thesis' Figure 6.6; ideal is the confidence itself. Produced by\n\n")
        f.write(f"    scripts/calibration.py --scenes {' '.join(args.scenes)} --passes {args.passes} "
                f"--photons {args.photons} --ref-passes {args.ref_passes} --scale {args.scale:g}\n\n")
        f.write("The reference has its own noise (it is added to the \"actual\" error), so coverage is\n"
                "slightly pessimistic at high pass counts.\n\n")
        f.write("| scene | confidence | passes | coverage | average estimated error (eq. 6.33) | relMSE |\n")
        f.write("| --- | --- | --- | --- | --- | --- |\n")
        for scene, conf, n, cov, est, rel in rows:
            f.write(f"| {scene} | {conf:.0%} | {n} | {cov:.1%} | {est:.4f} | {rel:.5f} |\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
