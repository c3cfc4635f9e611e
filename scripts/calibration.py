#!/usr/bin/python3
"""Calibration of the SPPM error estimate (thesis ch. 6, the measure of its Figure 6.6) and of
render-until-error (--target-error, §6.5.1).

Coverage: for each scene, error-bound form (error_bound = calibrated | thesis), confidence c and
seed, SPPM renders in process (the native module's Session) and, at each checkpoint pass count,
the share of pixels whose bound (the `error` pass times L, thesis eq. 6.13) is at least the
actual error |L - L_ref| (luminance) is measured.

The reference's own noise, removed statistically (every pixel counts). L_ref is the mean of two
independent references a and b; its error eps = L_ref - L has, per pixel, the distribution of
d = (a - b) / 2 (same variance; the same law for symmetric noise). If the bound were exactly
calibrated, the pixel's error would be bias + s Z (Z standard normal, bias the B' the bound uses,
s the sd at which P(|bias + s Z| <= bound) = c: the normal the bound asserts), and against the
noisy reference the expected coverage would be P_ref = P(|bias + s Z - d| <= bound), below c by
what the reference's noise costs. So

    coverage (reference noise removed) = observed + c - mean(P_ref)

estimates the coverage against the truth: exact in expectation when the bound is calibrated, and
to first order in the reference's noise otherwise. `ref cost` = c - mean(P_ref) is listed: where it
is large the reference decides little (its figure is then mostly the prediction), so the
references are made long enough to keep it small.

References per scene (--ref SCENE=METHOD[:k=v,...]@PASSES, default pt@--ref-passes): path traced
where path tracing converges (diffuse, glossy), else SPPM with a small initial radius and many
photons per pass, whose own residual bias (its B', mean |B'| / L) is listed beside it. They are
rendered in process at --ref-threads and cached under build/references/ as .npz.

Render-until-error: SPPM passes until its estimated error, the average (eq. 6.33) of every pixel's
estimated mean relative error E|e| / L, is at most E; the achieved mean relative error |L_i - L_ref| / L_ref over the same pixels (with the
reference's noise removed as above: mean over pixels of E|e| estimated by E|e - eps| minus what d
adds under the error's own asserted normal), the passes and the time are reported, per seed.
--confidences '' skips the coverage tables (a section with the stop table alone).

Results go between the markers `<!-- calibration.py NAME: begin -->` and `<!-- calibration.py
NAME: end -->` of --out (--section NAME), appended with the markers if the file has none;
everything outside the markers is kept.

    scripts/calibration.py --scenes cornell-box cornell-glass torus-glass glossy-caustics \\
        --passes 16,64,256,1024 --seeds 1,2,3 --scale 0.0625 --photons 5000 --targets 0.2,0.1,0.05
"""
import argparse
import json
import math
import pathlib
import shlex
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "build" / "python"))
sys.path.insert(0, str(ROOT / "scripts"))
from interleaved import parse_spec  # noqa: E402  ('sppm:photons=200000,footprint=0.25' -> name, params)

LUMA = np.array([0.2126, 0.7152, 0.0722])
_erf = np.frompyfunc(math.erf, 1, 1)


def Phi(x):
    return 0.5 * (1.0 + _erf(np.asarray(x, dtype=np.float64) / math.sqrt(2.0)).astype(np.float64))


def luminance(rgb):
    return rgb[..., :3] @ LUMA


def load_scene(native, scene_name, scale):
    j = json.loads((ROOT / "scenes" / f"{scene_name}.json").read_text())
    cam = j["camera"]
    cam["width"], cam["height"] = (max(1, round(cam.get(k, 256) * scale)) for k in ("width", "height"))
    return native.load_scene_json(json.dumps(j), str(ROOT / "scenes"))


def reference(native, scene_name, spec, seed, args):
    """Luminance of a long render (and its own |B'| where it is SPPM), cached by scene, size, spec, seed."""
    method_spec, _, passes = spec.partition("@")
    tag = "".join(c if c.isalnum() or c in "._-" else "_" for c in f"{scene_name}-x{args.scale:g}-{method_spec}-{passes}p-seed{seed}")
    path = ROOT / "build" / "references" / f"calibration-{tag}.npz"
    scene_file = ROOT / "scenes" / f"{scene_name}.json"
    if path.exists() and path.stat().st_mtime >= scene_file.stat().st_mtime:
        z = np.load(path)
        return z["L"], z["bias"]
    path.parent.mkdir(parents=True, exist_ok=True)
    name, params = parse_spec(method_spec)
    s = native.Session(load_scene(native, scene_name, args.scale), name, dict(params, seed=seed, threads=args.ref_threads))
    s.set_aux_passes(False)
    start = time.perf_counter()
    s.run(passes=int(passes))
    L = luminance(s.develop()["combined"].astype(np.float64))
    # An SPPM reference's own bias estimate B' (its residual bias, subtracted below: what is left
    # is the error of a small B', second order here).
    bias = s.error_terms()["bias"] if name in ("ppm", "sppm") else np.zeros_like(L)
    np.savez(path, L=L, bias=bias)
    print(f"reference {tag}: {time.perf_counter() - start:.0f} s", flush=True)
    return L, bias


def asserted_sd(bias, bound, c):
    """Per pixel, s with P(|bias + s Z| <= bound) = c: the normal around the bound's bias it asserts."""
    lo, hi = np.full_like(bound, 1e-30), np.maximum(bound, 1e-30) * 10
    for _ in range(60):
        s = 0.5 * (lo + hi)
        p = Phi((bound - bias) / s) - Phi((-bound - bias) / s)
        wide = p < c  # s too large: the bound covers less than c
        hi = np.where(wide, s, hi)
        lo = np.where(wide, lo, s)
    return 0.5 * (lo + hi)


def coverage(L, terms, ref, d, c):
    """(observed coverage, predicted against the noisy reference, corrected coverage) over the pixels with a bound."""
    bound, bias = terms["bound"], terms["bias"]
    valid = (L > 0) & np.isfinite(bound) & (bound > 0)
    L, bound, bias, r, d = L[valid], bound[valid], bias[valid], ref[valid], d[valid]
    observed = float(np.mean(np.abs(L - r) <= bound))
    s = asserted_sd(bias, bound, c)
    p_ref = float(np.mean(Phi((bound - bias + d) / s) - Phi((-bound - bias + d) / s)))
    return observed, p_ref, observed + c - p_ref


def session(native, scene, args, params):
    s = native.Session(scene, "sppm", dict(params, photons=args.photons, threads=args.threads))
    s.set_aux_passes(False)
    return s


def write_section(path, text, section):
    """Replace the text between this section's markers (append them if absent); nothing else changes."""
    name = f"calibration.py {section}".strip()
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    old = path.read_text() if path.exists() else ""
    if old.count(begin) > 1 or old.count(end) > 1 or ((begin in old) != (end in old)):
        raise SystemExit(f"{path}: the markers of section '{section}' are not one begin/end pair; nothing written")
    if begin in old:
        i, j = old.index(begin) + len(begin), old.index(end)
        if j < i:
            raise SystemExit(f"{path}: section '{section}' ends before it begins; nothing written")
        new = old[:i] + "\n" + text + old[j:]
    else:
        new = old + ("\n" if old and not old.endswith("\n") else "") + f"{begin}\n{text}{end}\n"
    path.write_text(new)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-glass", "torus-glass", "glossy-caustics"])
    ap.add_argument("--passes", default="16,64,256,1024", help="checkpoint pass counts")
    ap.add_argument("--confidences", default="0.5,0.75,0.9")
    ap.add_argument("--bounds", default="calibrated", help="error_bound values to compare")
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--photons", type=int, default=5000)
    ap.add_argument("--params", default="", help="further SPPM parameters, k=v,...")
    ap.add_argument("--targets", default="0.2,0.1,0.05", help="--target-error values for the stop table ('' for none)")
    ap.add_argument("--max-passes", type=int, default=4096, help="give up a target after this many passes")
    ap.add_argument("--ref-passes", type=int, default=65536)
    ap.add_argument("--ref", action="append", default=[], metavar="SCENE=METHOD[:k=v,...]@PASSES",
                    help="a scene's reference (default pt@--ref-passes)")
    ap.add_argument("--ref-seed", type=int, default=1000003)
    ap.add_argument("--ref-threads", type=int, default=1)
    ap.add_argument("--scale", type=float, default=0.0625)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "error-calibration.md")
    ap.add_argument("--section", default="", help="name of the marked section of --out to write")
    ap.add_argument("--references-only", action="store_true", help="render the references and stop")
    args = ap.parse_args()
    from gradphoton import _native as native

    checkpoints = [int(p) for p in args.passes.split(",")]
    confidences = [float(c) for c in args.confidences.split(",") if c]
    bounds = [b for b in args.bounds.split(",") if b]
    seeds = [int(s) for s in args.seeds.split(",")]
    targets = [float(t) for t in args.targets.split(",") if t]
    extra = parse_spec(":" + args.params)[1]
    ref_specs = dict(r.split("=", 1) for r in args.ref)
    cov_rows, stop_rows, ref_rows = [], [], []
    for scene_name in args.scenes:
        spec = ref_specs.get(scene_name, f"pt@{args.ref_passes}")
        (a, bias_a), (b, bias_b) = (reference(native, scene_name, spec, args.ref_seed + k, args) for k in (0, 1))
        if args.references_only:
            continue
        a, b = a - bias_a, b - bias_b
        ref, d = 0.5 * (a + b), 0.5 * (a - b)
        lit = ref > 0
        ref_noise = float(np.sqrt(np.mean(d[lit] ** 2 / ref[lit] ** 2)))
        ref_bias = float(np.mean(np.abs(0.5 * (bias_a + bias_b))[lit] / ref[lit]))
        ref_rows.append((scene_name, spec, ref_noise, ref_bias))
        scene = load_scene(native, scene_name, args.scale)
        for bound in bounds:
            for conf in confidences:
                per_pass = {n: [] for n in checkpoints}
                for seed in seeds:
                    s = session(native, scene, args, dict(extra, seed=seed, confidence=conf, error_bound=bound))
                    done = 0
                    for n in checkpoints:
                        s.run(passes=n - done)
                        done = n
                        terms = s.error_terms()
                        per_pass[n].append(coverage(terms["radiance"], terms, ref, d, conf))
                for n in checkpoints:
                    obs, pred, corr = (np.array(x) for x in zip(*per_pass[n]))
                    cov_rows.append((scene_name, bound, conf, n, corr.mean(), corr.min(), corr.max(), obs.mean(), conf - pred.mean()))
                    print(f"{scene_name:16s} {bound:10s} conf {conf:4.2f} passes {n:5d}  coverage {corr.mean():.3f} "
                          f"({corr.min():.3f}-{corr.max():.3f})  observed {obs.mean():.3f}  ref cost {conf - pred.mean():.3f}",
                          flush=True)
        for target, seed in ((t, sd) for t in targets for sd in seeds):
            s = session(native, scene, args, dict(extra, seed=seed, confidence=0.5))
            n = 0
            start = time.perf_counter()
            while n < args.max_passes and not (0 <= s.estimated_error <= target):
                s.iterate()
                n += 1
            seconds = time.perf_counter() - start
            terms = s.error_terms()
            L = terms["radiance"]
            valid = (L > 0) & (ref > 0) & np.isfinite(terms["bound"])
            raw = np.abs(L - ref)[valid]
            # The reference noise's share of E|e - eps|, under the error's asserted normal.
            bias, sd = terms["bias"][valid], asserted_sd(terms["bias"][valid], terms["bound"][valid], 0.5)
            def mean_abs(dd):  # E|bias + dd + sd Z| for a normal of sd sd
                m = bias + dd
                return sd * math.sqrt(2 / math.pi) * np.exp(-m * m / (2 * sd * sd)) + m * (1 - 2 * Phi(-m / sd))
            ref_share = mean_abs(d[valid]) - mean_abs(0 * d[valid])
            # Relative to the true radiance (the reference): |e| / L_i, over the render's own L_i, has
            # no finite mean (L_i is near 0 where a few photons were missed) and at few passes is
            # dominated by those pixels (docs/error-calibration.md); listed beside it.
            achieved_raw = float(np.mean(raw / ref[valid]))
            achieved = float(np.mean((raw - ref_share) / ref[valid]))
            per_Li = float(np.mean((raw - ref_share) / L[valid]))
            # The passes with photons of the pixels (the caustics' early-stop diagnosis).
            few = float(np.mean(terms["photon_passes"][valid] < n / 2))
            stop_rows.append((scene_name, target, seed, s.estimated_error, achieved, achieved_raw, per_Li, few, n, seconds))
            print(f"{scene_name:16s} target {target:.3f} seed {seed}: estimated {s.estimated_error:.4f} achieved {achieved:.4f} "
                  f"(against the noisy reference {achieved_raw:.4f}) passes {n} {seconds:.1f} s", flush=True)
    if args.references_only:
        return

    cmd = shlex.join(sys.argv[1:])
    lines = [f"Made by `scripts/calibration.py {cmd}`: {args.photons} photons per pass, images at "
             f"{args.scale:g} of each scene's size, seeds {args.seeds}"
             + ("; coverage with the reference's noise removed (observed + c - predicted against the noisy "
                "reference; every pixel counts).\n\n" if cov_rows else ".\n\n"),
             "| scene | reference (seeds " f"{args.ref_seed}, {args.ref_seed + 1}) | its noise (rms sd / L) | its own bias (mean abs B' / L, subtracted) |\n",
             "| --- | --- | --- | --- |\n"]
    for scene_name, spec, noise, rbias in ref_rows:
        lines.append(f"| {scene_name} | {spec} | {noise:.4f} | {rbias:.4f} |\n")
    if cov_rows:
        lines += ["\n| scene | bound | confidence | passes | coverage (mean over seeds) | min-max | observed | ref cost |\n",
                  "| --- | --- | --- | --- | --- | --- | --- | --- |\n"]
    for scene_name, bound, conf, n, mean, lo, hi, obs, cost in cov_rows:
        lines.append(f"| {scene_name} | {bound} | {conf:.0%} | {n} | {mean:.1%} | {lo:.1%}-{hi:.1%} | {obs:.1%} | {cost:.1%} |\n")
    if stop_rows:
        lines += ["\nRender until error (`--target-error E`, calibrated bound): the stop compares E with the "
                  "estimated error, the average over the pixels of eq. 6.33 of each one's estimated mean |e| / L_i; achieved = "
                  "mean |L_i - L| / L over the same pixels (L the true radiance), the reference's noise removed (beside it: against the noisy "
                  "reference); `over L_i`: mean |L_i - L| / L_i, divided by the render's own radiance; `few photon passes` = share of those pixels whose gathers found photons in fewer than half the "
                  "passes (the caustics' early stop); time is this machine's, shared, for scale only.\n\n",
                  "| scene | target E | seed | estimated at the stop | achieved | achieved / E | against the noisy reference "
                  "| over L_i / E | few photon passes | passes | seconds |\n",
                  "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n"]
        for scene_name, target, seed, est, achieved, raw, per_Li, few, n, seconds in stop_rows:
            lines.append(f"| {scene_name} | {target:g} | {seed} | {est:.4f} | {achieved:.4f} | {achieved / target:.2f} | "
                         f"{raw:.4f} | {per_Li / target:.2f} | {few:.1%} | {n} | {seconds:.1f} |\n")
    write_section(args.out, "".join(lines), args.section)
    print(f"wrote the section of {args.out}")


if __name__ == "__main__":
    main()
