#!/usr/bin/env python3
"""Throughput regression benchmark: how close the renderer runs to raw Embree, per scene.

For every scene (default: all of scenes/) it runs `gradphoton bench` and `gradphoton
bench-photons` and prints one row of ratios, each measured side by side inside one command
(raw replays and rendering alternate in rounds, so a shared machine's load weighs on both):

  pt/raw        path tracer rays/s over bare single-ray Embree on the path tracer's own rays
  pt/streams    the same over Embree's stream interface (rtcIntersect1M / rtcOccluded1M)
  photon/raw    photon tracing rays/s over bare Embree on the photon tracer's own rays
  eye share     SPPM with its defaults: the eye pass's share of a pass
  (lookup+update)/trace   SPPM at --photons per pass

and the goals of issue 18 beside them (pt/raw >= 0.7, photon/raw >= 0.8, eye share <= 0.25,
(lookup+update)/trace <= 0.33). With --baseline OTHER_BINARY every command also runs with that
binary, alternating the two, so a change can be compared with the build before it:

  scripts/bench_throughput.py --threads 2
  scripts/bench_throughput.py --scenes cornell-box cornell-dense --baseline /tmp/before/gradphoton
  scripts/bench_throughput.py --json out.json     # the parsed numbers, for later comparison

Timed claims go to docs/benchmarks.md with the command and the machine's load.
"""
import argparse
import json
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GOALS = {"pt/raw": (">=", 0.7), "photon/raw": (">=", 0.8), "eye share": ("<=", 0.25),
         "(lookup+update)/trace": ("<=", 0.33)}
COLUMNS = ["pt/raw", "pt/streams", "photon/raw", "photon/streams", "eye share", "(lookup+update)/trace"]

# Output line of each command -> column (the first number after the label).
PATTERNS = {
    "bench": {"pt/raw": r"^path tracer / embree\s+([\d.]+)", "pt/streams": r"^path tracer / streams\s+([\d.]+)",
              "triangles": r"^scene\s+\S+ \((\d+) triangles"},
    "bench-photons": {"photon/raw": r"^photon tracing / embree\s+([\d.]+)",
                      "photon/streams": r"^photon tracing / streams\s+([\d.]+)",
                      "eye share": r"^sppm eye share\s+([\d.]+)",
                      "(lookup+update)/trace": r"^\(lookup \+ update\) / trace\s+([\d.]+)"},
}


# Lines that older builds (a --baseline) do not print.
OPTIONAL = {"pt/streams", "photon/streams", "eye share"}


def parse(kind, text):
    """The numbers of one command's output; raises naming the line it could not find."""
    out = {}
    for key, pat in PATTERNS[kind].items():
        m = re.search(pat, text, re.M)
        if not m and key not in OPTIONAL:
            raise RuntimeError(f"gradphoton {kind}: no line matching {pat!r} in its output:\n{text}")
        out[key] = float(m.group(1)) if m else None
    return out


def run(binary, kind, scene, args):
    cmd = [binary, kind, scene, "--threads", str(args.threads)]
    if kind == "bench":
        cmd += ["--seconds", str(args.seconds)]
    else:
        cmd += ["--photons", str(args.photons), "--passes", str(args.passes), "--width", str(args.width)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}):\n{res.stderr}")
    if args.verbose:
        print(res.stdout, file=sys.stderr)
    return parse(kind, res.stdout)


def cell(col, value):
    return "-" if value is None else f"{value:.2f}{meets(col, value)}"


def meets(col, value):
    if col not in GOALS:
        return ""
    op, goal = GOALS[col]
    return "" if (value >= goal if op == ">=" else value <= goal) else "*"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="*", help="scene names or files (default: every scenes/*.json)")
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "gradphoton"))
    ap.add_argument("--baseline", help="another gradphoton binary, run alternately with --binary")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=3, help="bench: least seconds of alternating rounds")
    ap.add_argument("--photons", type=int, default=1000000, help="bench-photons: photons per pass")
    ap.add_argument("--passes", type=int, default=3, help="bench-photons: passes timed")
    ap.add_argument("--width", type=int, default=256, help="bench-photons: image width")
    ap.add_argument("--json", help="also write the numbers here")
    ap.add_argument("-v", "--verbose", action="store_true", help="echo each command's output to stderr")
    args = ap.parse_args()

    scenes = args.scenes or sorted(f[:-5] for f in os.listdir(os.path.join(ROOT, "scenes")) if f.endswith(".json"))
    paths = [s if s.endswith(".json") else os.path.join(ROOT, "scenes", s + ".json") for s in scenes]
    for p in paths:
        if not os.path.isfile(p):
            sys.exit(f"bench_throughput: no scene file {p}")
    binaries = [("new", args.binary)] + ([("base", args.baseline)] if args.baseline else [])
    for _, b in binaries:
        if not os.access(b, os.X_OK):
            sys.exit(f"bench_throughput: {b} is not an executable (build it first)")
    load = os.getloadavg()[0]
    print(f"threads {args.threads}, load average {load:.1f} at the start; '*' = misses the goal "
          f"({', '.join(f'{k} {op} {v}' for k, (op, v) in GOALS.items())})")
    header = ["scene", "triangles"] + (["binary"] if args.baseline else []) + COLUMNS
    print(" | ".join(header))
    results = {}
    for name, path in zip(scenes, paths):
        rows = {tag: {} for tag, _ in binaries}
        for kind in ("bench", "bench-photons"):  # alternate the binaries command by command
            for tag, b in binaries:
                rows[tag].update(run(b, kind, path, args))
        results[name] = rows
        for tag, _ in binaries:
            r = rows[tag]
            cells = [name, str(int(r["triangles"]))] + ([tag] if args.baseline else [])
            cells += [cell(c, r[c]) for c in COLUMNS]
            print(" | ".join(cells), flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"threads": args.threads, "load_start": load, "results": results}, f, indent=1)


if __name__ == "__main__":
    main()
