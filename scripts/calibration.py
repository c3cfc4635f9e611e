#!/usr/bin/python3
"""Calibration of the SPPM error estimate (thesis ch. 6, the measure of its Figure 6.6) and of
render-until-error (--target-error, §6.5.1).

Coverage: for each scene, error-bound form (error_bound = calibrated | thesis), confidence and
seed, SPPM renders in process (the native module's Session) and, at each checkpoint pass count,
the share of pixels whose bound (the `error` pass times L, thesis eq. 6.13) is at least the
actual error |L - L_ref| (luminance) is measured. L_ref is the mean of two independent
references (convergence.py's split references); the reference's own noise is removed by leaving out the pixels where it exceeds --ref-tolerance times
the bound (their share is reported): there the reference cannot tell whether the bound holds.
Its sd per pixel is estimated from the split, (a - b)^2 / 4 averaged over the pixel's 5 x 5
neighbourhood: from one pixel's two samples alone it is often small by chance, which kept
pixels whose "actual" error was the reference's.

Render-until-error: SPPM with the calibrated bound at 50 % confidence passes until its average
estimated error (eq. 6.33) is at most E; the achieved average relative error over the same pixels
against L_ref, the passes and the time are reported.

Results go between the markers `<!-- calibration.py: begin -->` and `<!-- calibration.py: end -->`
of --out (with --section NAME: `<!-- calibration.py NAME: begin -->` ...), appended with the
markers if the file has none; everything else in the file is kept.

    scripts/calibration.py --scenes cornell-box cornell-glass torus-glass glossy-caustics \\
        --passes 16,64,256 --seeds 1,2,3 --scale 0.125 --targets 0.2,0.1,0.05
"""
import argparse
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "build" / "python"))
from convergence import read_combined, reference, size_args  # noqa: E402

LUMA = np.array([0.2126, 0.7152, 0.0722])


def luminance(rgb):
    return rgb[..., :3] @ LUMA


def session(native, scene_name, args, params):
    import json
    text = (ROOT / "scenes" / f"{scene_name}.json").read_text()
    j = json.loads(text)
    size = size_args(scene_name, args)
    j["camera"]["width"], j["camera"]["height"] = size[1], size[3]
    scene = native.load_scene_json(json.dumps(j), str(ROOT / "scenes"))
    s = native.Session(scene, "sppm", dict(params, photons=args.photons, threads=args.threads))
    s.set_aux_passes(False)
    return s


def local_mean(x, k=2):
    """Mean over the (2k + 1)^2 neighbourhood (edges: the part inside the image)."""
    pad = np.pad(x, k, mode="constant")
    ones = np.pad(np.ones_like(x), k, mode="constant")
    c = lambda a: np.cumsum(np.cumsum(np.pad(a, ((1, 0), (1, 0))), 0), 1)
    s, n = c(pad), c(ones)
    w = 2 * k + 1
    box = lambda t: t[w:, w:] - t[:-w, w:] - t[w:, :-w] + t[:-w, :-w]
    return box(s) / box(n)


def coverage(img, err, ref, ref_sd, tolerance):
    """Share of pixels with a bound covering |L - L_ref|, and the share left out for the reference's noise."""
    L = luminance(img)
    bound = err[..., 0] * L
    valid = (L > 0) & np.isfinite(bound)
    decided = valid & (ref_sd <= tolerance * bound)
    covered = np.abs(L - ref) <= bound
    return float(covered[decided].mean()), 1.0 - float(decided.sum()) / max(1, int(valid.sum()))


def write_section(path, text, section=""):
    name = f"calibration.py {section}".strip()
    BEGIN, END = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    old = path.read_text() if path.exists() else ""
    block = f"{BEGIN}\n{text}{END}\n"
    if BEGIN in old and END in old:
        new = old[:old.index(BEGIN)] + block + old[old.index(END) + len(END):].lstrip("\n")
    else:
        new = old + ("\n" if old and not old.endswith("\n") else "") + block
    path.write_text(new)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-glass", "torus-glass", "glossy-caustics"])
    ap.add_argument("--passes", default="16,64,256", help="checkpoint pass counts")
    ap.add_argument("--confidences", default="0.5,0.75,0.9")
    ap.add_argument("--bounds", default="calibrated,thesis", help="error_bound values to compare")
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--photons", type=int, default=20000)
    ap.add_argument("--targets", default="0.2,0.1,0.05", help="--target-error values for the stop table ('' for none)")
    ap.add_argument("--max-passes", type=int, default=4096, help="give up a target after this many passes")
    ap.add_argument("--ref-passes", type=int, default=4096)
    ap.add_argument("--ref-method", default="pt")
    ap.add_argument("--ref-seed", type=int, default=1000003)
    ap.add_argument("--scale", type=float, default=0.125)
    ap.add_argument("--ref-tolerance", type=float, default=0.5,
                    help="leave out pixels whose reference noise sd exceeds this times the bound")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "error-calibration.md")
    ap.add_argument("--section", default="", help="name of the marked section of --out to write")
    args = ap.parse_args()
    from gradphoton import _native as native

    checkpoints = [int(p) for p in args.passes.split(",")]
    confidences = [float(c) for c in args.confidences.split(",")]
    bounds = [b for b in args.bounds.split(",") if b]
    seeds = [int(s) for s in args.seeds.split(",")]
    targets = [float(t) for t in args.targets.split(",") if t]
    cov_rows, stop_rows = [], []
    for scene in args.scenes:
        a = luminance(read_combined(reference(scene, args)))
        b = luminance(read_combined(reference(scene, args, args.ref_seed + 1)))
        ref, ref_sd = 0.5 * (a + b), np.sqrt(local_mean((a - b) ** 2 / 4))
        for bound in bounds:
            for conf in confidences:
                per_pass = {n: [] for n in checkpoints}
                for seed in seeds:
                    s = session(native, scene, args, {"seed": seed, "confidence": conf, "error_bound": bound})
                    done = 0
                    for n in checkpoints:
                        while done < n:
                            s.iterate()
                            done += 1
                        passes = s.develop()
                        per_pass[n].append(coverage(passes["combined"], passes["error"], ref, ref_sd, args.ref_tolerance))
                for n in checkpoints:
                    covs = [c for c, _ in per_pass[n]]
                    left = np.mean([x for _, x in per_pass[n]])
                    cov_rows.append((scene, bound, conf, n, np.mean(covs), min(covs), max(covs), left))
                    print(f"{scene:16s} {bound:10s} conf {conf:4.2f} passes {n:5d}  coverage {np.mean(covs):.3f} "
                          f"({min(covs):.3f}-{max(covs):.3f})  left out {left:.3f}", flush=True)
        for target in targets:
            s = session(native, scene, args, {"seed": seeds[0], "confidence": 0.5})
            n = 0
            start = time.perf_counter()
            while n < args.max_passes and not (0 <= s.estimated_error <= target):
                s.iterate()
                n += 1
            seconds = time.perf_counter() - start
            img = s.develop()["combined"]
            L = luminance(img)
            valid = (L > 0) & (ref > 0)
            achieved = float(np.mean(np.abs(L[valid] - ref[valid]) / L[valid]))
            ref_part = float(np.mean(ref_sd[valid] / L[valid]))
            stop_rows.append((scene, target, s.estimated_error, achieved, ref_part, n, seconds))
            print(f"{scene:16s} target {target:.3f}: estimated {s.estimated_error:.4f} achieved {achieved:.4f} "
                  f"(reference noise {ref_part:.4f}) passes {n} {seconds:.1f} s", flush=True)

    cmd = " ".join(sys.argv[1:])
    lines = [f"Made by `scripts/calibration.py {cmd}`: {args.photons} photons per pass, images at "
             f"{args.scale:g} of each scene's size, references {args.ref_method} {args.ref_passes} passes "
             f"(seeds {args.ref_seed} and {args.ref_seed + 1}), seeds {args.seeds}; pixels whose reference noise "
             f"sd exceeds {args.ref_tolerance:g} x the bound left out.\n\n",
             "| scene | bound | confidence | passes | coverage (mean over seeds) | min-max | pixels left out |\n",
             "| --- | --- | --- | --- | --- | --- | --- |\n"]
    for scene, bound, conf, n, mean, lo, hi, left in cov_rows:
        lines.append(f"| {scene} | {bound} | {conf:.0%} | {n} | {mean:.1%} | {lo:.1%}-{hi:.1%} | {left:.1%} |\n")
    if stop_rows:
        lines += ["\nRender until error (`--target-error E`, calibrated bound, 50 % confidence, seed "
                  f"{seeds[0]}): achieved = mean |L - L_ref| / L over the pixels of eq. 6.33; the reference's own "
                  "noise (mean sd / L) is listed beside it; time is this machine's, shared, for scale only.\n\n",
                  "| scene | target E | estimated at the stop | achieved | achieved / E | reference noise | passes | seconds |\n",
                  "| --- | --- | --- | --- | --- | --- | --- | --- |\n"]
        for scene, target, est, achieved, ref_part, n, seconds in stop_rows:
            lines.append(f"| {scene} | {target:g} | {est:.4f} | {achieved:.4f} | {achieved / target:.2f} | "
                         f"{ref_part:.4f} | {n} | {seconds:.1f} |\n")
    write_section(args.out, "".join(lines), args.section)
    print(f"wrote the section of {args.out}")


if __name__ == "__main__":
    main()
