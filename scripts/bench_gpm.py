#!/usr/bin/python3
"""GPM against SPPM: cost per pass, or equal-time error as users render (issue 34).

Cost (the default): runs sppm, gpm without the walk (manifold_iterations 0) and gpm interleaved,
`--repeats` times each, same seed, size and photons, and prints the median seconds per pass of
each, the ratios, and gpm's split of a pass (eye / trace / lookup+shifts / update seconds).

  scripts/bench_gpm.py [--scenes cornell-box cornell-glass torus-glass] [--size 128] [--photons 100000]
                       [--passes 4] [--repeats 3]

Error (`scripts/bench_gpm.py error ...`): equal-time relMSE of sppm, gpm-L1 and gpm-L2 at their
defaults and of gpm over a sweep of photons per pass, each render alone (one at a time, never
side by side) at `--threads` (2), against a long reference: see `scripts/bench_gpm.py error --help`.
"""
import argparse
import csv
import json
import os
import pathlib
import re
import statistics
import subprocess
import sys
import tempfile

from convergence import method_args  # noqa: E402  (scripts/ is on the path when run)

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


ERROR_DOC = """Equal-time error of GPM against SPPM, rendered as users render (issue 34).

Every render runs alone (one at a time) at --threads threads, full size, for the largest budget,
with snapshots at every budget (`--checkpoints`); relMSE of each snapshot's combined pass against
the scene's reference, less the reference's own noise when the reference has two halves (two
seeds: convergence.py's SplitReference). Configurations, per scene and seed:
  sppm, gpm (recon l1) and gpm (recon l2) with their defaults, then gpm l1 and l2 with
  --photons P for every P of --photons (the sweep that sets GPM's default photons per pass).
Prints a table per scene (relMSE and gpm / sppm at each budget), writes every row to --csv.

Scenes are NAME or NAME:WxH (default size: the scene file's camera; torus-glass at 256x256, the
public GPM code's torus). References: --reference NAME=A.exr[,B.exr] reads them (B: the second
half of a split reference); otherwise two halves are rendered with --ref-method (default a
sharp fixed-radius SPPM) for --ref-passes passes each at seeds ref-seed and ref-seed + 1, with
all cores, and cached under build/references/.

The measurement the lead runs on a quiet 16-core machine (nothing else running; note the load
average), about 4 scenes x 11 renders x 60 s plus the references:
  scripts/bench_gpm.py error --budgets 8,60 --threads 2 --photons 100000,250000,500000,1000000 \\
      --scenes torus-glass:256x256 cornell-glass sun-caustic cornell-box --ref-passes 4000
Equal counted work instead of equal time (`--passes N`, for a shared machine, where seconds mean
little): gpm's configurations render N passes each, no snapshots, and the table prints each
run's counted work (`eye work` + `photon work` of the render's statistics, in eye rays: gpm.h
GpmPassWork), so runs compare at equal work where the work matches (GPM's photon rule keeps a
pass's photon work equal to its eye work, so a change to the gather's cost alone keeps the work
of N passes; one that changes the eye pass needs N scaled by the work printed). sppm has no
counted work and is left out. Both modes print relMSE without the worst 0.1 % of pixels too
(`trim`): a caustic's focus decides a few pixels by which photons happened to land there, and
that column shows whether a difference is more than those pixels.
  scripts/bench_gpm.py error --passes 100 --photons "" --scenes sun-caustic \
      --config "gpm-L1 footprint 0.75=gpm:recon=l1,gradient_footprint=0.75" --reference sun-caustic=A.exr,B.exr
A tiny check that it works: scripts/bench_gpm.py error --budgets 1,2 --scenes torus-glass:32x32 \\
      --photons 10000 --ref-passes 20
"""


def scene_size(spec):
    """'torus-glass:256x256' -> ('torus-glass', 256, 256); a bare name takes its camera's size."""
    name, _, size = spec.partition(":")
    if size:
        w, h = (int(v) for v in size.lower().split("x"))
        return name, w, h
    if name == "torus-glass":
        return name, 256, 256  # the size: the public code's torus
    cam = json.loads((ROOT / "scenes" / f"{name}.json").read_text()).get("camera", {})
    return name, int(cam.get("width", 256)), int(cam.get("height", 256))


def tag(text):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text)


def run_logged(cmd):
    cmd = [str(c) for c in cmd]
    print("+", " ".join(cmd), file=sys.stderr, flush=True)
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


def error_references(opts, name, w, h, given):
    """The two halves of the scene's reference (the second None when one file was given)."""
    if name in given:
        paths = [pathlib.Path(p) for p in given[name].split(",")]
        return paths[0], (paths[1] if len(paths) > 1 else None)
    ref_dir = ROOT / "build" / "references"
    ref_dir.mkdir(parents=True, exist_ok=True)
    halves = []
    for seed in (opts.ref_seed, opts.ref_seed + 1):
        path = ref_dir / f"{name}-{w}x{h}-{tag(opts.ref_method)}-{opts.ref_passes}p-seed{seed}.exr"
        if not path.exists():
            run_logged([opts.cli, "render", ROOT / "scenes" / f"{name}.json", *method_args(opts.ref_method),
                        "--passes", opts.ref_passes, "--seed", seed, "--width", w, "--height", h,
                        "--param", f"threads={opts.ref_threads}", "-o", path])
        halves.append(path)
    return halves[0], halves[1]


def main_error(argv):
    ap = argparse.ArgumentParser(prog="bench_gpm.py error", description=ERROR_DOC,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["torus-glass:256x256", "cornell-glass", "sun-caustic", "cornell-box"])
    ap.add_argument("--budgets", default="8,60", help="render seconds, comma separated (snapshots of one render)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--passes", type=int, default=0,
                    help="render gpm's configurations for this many passes (counted work) instead of --budgets")
    ap.add_argument("--photons", default="100000,250000,500000,1000000",
                    help="photons per pass swept for gpm l1 and l2 (empty: defaults only)")
    ap.add_argument("--seeds", default="1", help="render seeds, comma separated (each a full set of renders)")
    ap.add_argument("--config", action="append", default=[], metavar="LABEL=METHOD:k=v,...",
                    help="a further configuration, e.g. 'gpm-L1 nee-off=gpm:recon=l1,gradient_nee=false'")
    ap.add_argument("--reference", action="append", default=[], metavar="SCENE=A.exr[,B.exr]")
    ap.add_argument("--ref-method", default="sppm:photons=200000,footprint=0.15,alpha=0.99999",
                    help="a sharp reference: fixed radius of 0.15 pixel (docs/gradient.md)")
    ap.add_argument("--ref-passes", type=int, default=4000)
    ap.add_argument("--ref-seed", type=int, default=1000003)
    ap.add_argument("--ref-threads", type=int, default=0, help="threads of the reference renders (0: all)")
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "build" / "bench_gpm")
    ap.add_argument("--csv", default="error.csv", help="table written under --out")
    ap.add_argument("--cli", default=str(ROOT / "build" / "gradphoton"))
    opts = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "scripts"))
    from convergence import SplitReference, read_combined

    budgets = [float(t) for t in opts.budgets.split(",")]
    sweep = [int(p) for p in filter(None, opts.photons.split(","))]
    configs = [("sppm", "sppm"), ("gpm-L1", "gpm:recon=l1"), ("gpm-L2", "gpm:recon=l2")]
    for p in sweep:
        configs += [(f"gpm-L1 {p}", f"gpm:recon=l1,photons={p}"), (f"gpm-L2 {p}", f"gpm:recon=l2,photons={p}")]
    configs += [tuple(c.split("=", 1)) for c in opts.config]
    if opts.passes:
        configs = [c for c in configs if not c[1].startswith("sppm")]
        budgets = [0.0]  # one image per run, at its last pass
    given = dict(r.split("=", 1) for r in opts.reference)
    opts.out.mkdir(parents=True, exist_ok=True)
    print(f"load average {os.getloadavg()[0]:.2f} at the start; {opts.threads} threads; one render at a time")
    rows = []
    for spec in opts.scenes:
        name, w, h = scene_size(spec)
        ref_a, ref_b = error_references(opts, name, w, h, given)
        if ref_b is not None:
            ref = SplitReference.from_files(ref_a, ref_b)
        else:
            a = read_combined(ref_a)
            ref = SplitReference(a, a)  # one file: no noise term
        for seed in (int(s) for s in opts.seeds.split(",")):
            for label, method in configs:
                stop = ["--passes", opts.passes] if opts.passes else \
                    ["--time", max(budgets), "--checkpoints", ",".join(f"{t:g}" for t in budgets)]
                out = opts.out / f"{name}-{w}x{h}-{tag(method)}-{'p%d' % opts.passes if opts.passes else 't'}-seed{seed}.exr"
                text = run_logged([opts.cli, "render", ROOT / "scenes" / f"{name}.json", *method_args(method), *stop,
                                   "--param", f"threads={opts.threads}", "--seed", seed, "--width", w, "--height", h,
                                   "-o", out])
                # The whole render's statistics: passes, and the eye pass's share of a pass (the
                # issue's aim: under a quarter).
                stat = lambda key: float((re.search(rf"^{key}\s+([0-9.e+-]+)", text, re.M) or [0, "nan"])[1])
                passes, eye_share = stat("passes"), stat("eye seconds") / stat("seconds")
                work = stat("eye work") + stat("photon work")  # counted, in eye rays (gpm only)
                for t in budgets:
                    snap = out if opts.passes else out.with_name(f"{out.stem}.{t:g}s.exr")
                    if not snap.exists():
                        continue
                    image = read_combined(snap)
                    raw, excess = ref.errors(image)
                    rows.append({"scene": name, "size": f"{w}x{h}", "seed": seed, "config": label, "method": method,
                                 "seconds": t, "relmse": raw, "relmse_excess": excess,
                                 "relmse_trim": ref.trimmed(image), "passes_at_end": passes,
                                 "eye_share": round(eye_share, 3), "work_M": round(work / 1e6, 2),
                                 "eye_work_share": round(stat("eye work") / work, 3) if work > 0 else float("nan"),
                                 "load": round(os.getloadavg()[0], 2)})
        # The scene's table: mean over seeds of relMSE less the reference's noise, and gpm / sppm.
        mean, trim = {}, {}
        for label, _ in configs:
            for t in budgets:
                sel = [r for r in rows if r["scene"] == name and r["config"] == label and r["seconds"] == t]
                mean[label, t] = statistics.mean(r["relmse_excess"] for r in sel) if sel else float("nan")
                trim[label, t] = statistics.mean(r["relmse_trim"] for r in sel) if sel else float("nan")
        base = "sppm" if not opts.passes else configs[0][0]
        print(f"\n{name} {w}x{h}: relMSE less the reference's noise (and / {base}'s), and without the worst 0.1 % "
              f"of pixels (trim), load {os.getloadavg()[0]:.2f}")
        cols = [f"{opts.passes} passes"] if opts.passes else [f"{t:g} s" for t in budgets]
        print(f"{'config':18}" + "".join(f"{c:>20}{'trim':>10}" for c in cols) + "   passes  eye share  work (M)")
        for label, _ in configs:
            cells = "".join(f"{mean[label, t]:11.5f} ({mean[label, t] / mean[base, t]:5.2f}){trim[label, t]:10.5f}"
                            for t in budgets)
            last = [r for r in rows if r["scene"] == name and r["config"] == label]
            tail = (f"   {last[-1]['passes_at_end']:6.0f}  {last[-1]['eye_share']:9.2f}  {last[-1]['work_M']:8.1f}"
                    if last else "")
            print(f"{label:18}{cells}{tail}", flush=True)
    path = opts.out / opts.csv
    with open(path, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["scene"])
        wr.writeheader()
        wr.writerows(rows)
    print(f"wrote {path}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "error":
        main_error(sys.argv[2:])
    else:
        main()
