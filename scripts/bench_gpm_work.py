#!/usr/bin/python3
"""GPM configurations at equal counted work, snapshots at given work levels (issue 34).

On a shared machine seconds mean little; GPM's render statistics count its work (`eye work` +
`photon work`, in eye rays: gpm.h GpmPassWork), which does not depend on load or threads. This
renders each configuration through the native module pass by pass and develops (reconstructs) the
image after the first pass at which the counted work reaches each of --work (millions of eye
rays), so configurations whose passes cost different work still compare at (nearly) equal work:
the row records the work actually done (a pass overshoots the level by at most one pass).
relMSE less the split reference's noise, and without the worst 0.1 % of pixels (trim), as
`bench_gpm.py error` (convergence.py SplitReference). Rows are appended to --csv; --table prints
the mean over seeds per scene, configuration and work level.

  scripts/bench_gpm_work.py --scene cornell-glass --work 40,80,160 --seeds 1,2,3 \\
      --config "default=gpm:recon=l1" --config "100k=gpm:recon=l1,photons=100000" \\
      --reference /work/refs/cornell-glass-ref-1000003.exr,/work/refs/cornell-glass-ref-1000004.exr
  scripts/bench_gpm_work.py --table --csv build/bench_gpm_work.csv
"""
import argparse
import csv
import os
import pathlib
import statistics
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "build" / "python"))


def parse_config(text):
    """'label=method:k=v,...' -> (label, method, params) (interleaved.py's method spec)."""
    from interleaved import parse_spec
    label, _, spec = text.partition("=")
    return (label, *parse_spec(spec))


def render(native, scene_path, size, method, params, seed, levels, threads):
    """[(work, passes, photons, eye share of the work, combined image)] at each work level."""
    from interleaved import load_scene_at
    scene = load_scene_at(str(scene_path), size)
    session = native.Session(scene, method, {**params, "seed": seed, "threads": threads})
    session.set_aux_passes(False)
    out, todo = [], sorted(levels)
    while todo:
        session.iterate()
        st = session.stats
        work = st["eye work"] + st["photon work"]
        if work >= todo[0] * 1e6:
            while todo and work >= todo[0] * 1e6:
                todo.pop(0)
            image = session.develop()["combined"].astype("float64")
            out.append((work, st["passes"], st["photons traced"], st["eye work"] / work, image))
    return out


def table(path):
    rows = list(csv.DictReader(open(path)))
    keys = sorted({(r["scene"], r["level"]) for r in rows}, key=lambda k: (k[0], float(k[1])))
    labels = list(dict.fromkeys(r["label"] for r in rows))
    for scene, level in keys:
        print(f"\n{scene} at {level} M eye rays of counted work: mean over seeds (relMSE excess, trim), work, passes")
        base = None
        for label in labels:
            sel = [r for r in rows if r["scene"] == scene and r["level"] == level and r["label"] == label]
            if not sel:
                continue
            m = statistics.mean(float(r["relmse_excess"]) for r in sel)
            t = statistics.mean(float(r["relmse_trim"]) for r in sel)
            base = base or (m, t)
            seeds = " ".join(f"{float(r['relmse_excess']):.5f}" for r in sel)
            print(f"  {label:24} {m:.5f} ({m / base[0]:4.2f})  trim {t:.5f} ({t / base[1]:4.2f})  "
                  f"work {statistics.mean(float(r['work_M']) for r in sel):6.1f}  "
                  f"passes {statistics.mean(float(r['passes']) for r in sel):5.1f}  "
                  f"photons/pass {statistics.mean(float(r['photons']) / float(r['passes']) for r in sel):8.0f}  "
                  f"eye {statistics.mean(float(r['eye_share']) for r in sel):.2f}  seeds: {seeds}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene")
    ap.add_argument("--size", default="", help="WxH (default: the scene file's)")
    ap.add_argument("--work", default="", help="work levels, millions of eye rays, comma separated")
    ap.add_argument("--seeds", default="1")
    ap.add_argument("--config", action="append", default=[], metavar="LABEL=METHOD:k=v,...")
    ap.add_argument("--reference", default="", help="A.exr,B.exr: the two halves of a split reference")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--csv", default=str(ROOT / "build" / "bench_gpm_work.csv"))
    ap.add_argument("--table", action="store_true", help="print the table of --csv and stop")
    opts = ap.parse_args()
    if opts.table:
        table(opts.csv)
        return
    from gradphoton import _native as native
    from convergence import SplitReference
    a, b = opts.reference.split(",")
    ref = SplitReference.from_files(a, b)
    levels = [float(w) for w in opts.work.split(",")]
    new = not os.path.exists(opts.csv)
    with open(opts.csv, "a", newline="") as f:
        wr = csv.writer(f)
        if new:
            wr.writerow(["scene", "label", "method", "seed", "level", "work_M", "passes", "photons",
                         "eye_share", "relmse_excess", "relmse_trim", "load", "seconds"])
        for seed in (int(s) for s in opts.seeds.split(",")):
            for text in opts.config:
                label, method, params = parse_config(text)
                t0 = time.time()
                snaps = render(native, ROOT / "scenes" / f"{opts.scene}.json", opts.size, method, params, seed, levels,
                               opts.threads)
                for level, (work, passes, photons, eye, image) in zip(levels, snaps):
                    _, excess = ref.errors(image)
                    wr.writerow([opts.scene, label, text, seed, level,
                                 round(work / 1e6, 2), passes, photons, round(eye, 3), excess, ref.trimmed(image),
                                 round(os.getloadavg()[0], 1), round(time.time() - t0, 1)])
                    print(f"{opts.scene} {label} seed {seed} {level} M: work {work / 1e6:.1f} passes {passes} "
                          f"relMSE {excess:.5f} trim {ref.trimmed(image):.5f} eye {eye:.2f}", flush=True)
                f.flush()


if __name__ == "__main__":
    main()
