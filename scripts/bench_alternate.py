#!/usr/bin/env python3
"""Before/after timing of one gradphoton command: two (or more) builds run alternately.

Runs the same `gradphoton` arguments with each binary in turn, --repeats rounds, and prints per
binary the median (and range) of the statistics the command prints (`seconds`, `eye seconds`,
`trace seconds`, ... : any "name  number" line), then each median over the first binary's. The
binaries alternate run by run, so a shared machine's load weighs on both alike:

  scripts/bench_alternate.py --bin /tmp/before/gradphoton build/gradphoton --repeats 5 -- \\
      render scenes/pool.json --method sppm --passes 8 --width 256 --height 192 -o /tmp/x.exr

Timed claims go to docs/benchmarks.md with the command and the machine's load.
"""
import argparse
import os
import re
import statistics
import subprocess
import sys

LINE = re.compile(r"^([a-zA-Z][\w ./+()-]*?)\s{2,}([-+0-9.eE]+)\s*$")


def stats_of(text):
    """Every 'name   number' line of a gradphoton command's output."""
    out = {}
    for line in text.splitlines():
        m = LINE.match(line.strip())
        if m:
            try:
                out[m.group(1).strip()] = float(m.group(2))
            except ValueError:
                pass
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", nargs="+", required=True, help="gradphoton binaries; the first is the baseline")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--keys", nargs="*", default=["seconds", "eye seconds", "trace seconds"],
                    help="statistics to report (default: seconds, eye seconds, trace seconds)")
    ap.add_argument("args", nargs=argparse.REMAINDER, help="-- then the gradphoton arguments")
    a = ap.parse_args()
    args = a.args[1:] if a.args[:1] == ["--"] else a.args
    if not args:
        sys.exit("bench_alternate.py: give the gradphoton arguments after --")
    for b in a.bin:
        if not os.access(b, os.X_OK):
            sys.exit(f"bench_alternate.py: {b} is not an executable")
    runs = {b: [] for b in a.bin}
    for r in range(a.repeats):
        order = a.bin if r % 2 == 0 else list(reversed(a.bin))  # neither always goes first
        for b in order:
            p = subprocess.run([b] + args, capture_output=True, text=True)
            if p.returncode != 0:
                sys.exit(f"bench_alternate.py: {b} {' '.join(args)} failed ({p.returncode}):\n{p.stderr}")
            runs[b].append(stats_of(p.stdout + p.stderr))
    print("command: gradphoton " + " ".join(args))
    print(f"repeats: {a.repeats}, alternating; median (min..max)")
    base = a.bin[0]
    for key in a.keys:
        med = {}
        for b in a.bin:
            vals = [s[key] for s in runs[b] if key in s]
            if not vals:
                continue
            med[b] = statistics.median(vals)
            ratio = f"  x{med[b] / med[base]:.3f}" if b != base and med.get(base) else ""
            print(f"  {key:<14} {med[b]:9.4f} ({min(vals):.4f}..{max(vals):.4f})  {b}{ratio}")
    # The eye pass's share of a pass, where the command prints both.
    for b in a.bin:
        shares = [s["eye seconds"] / s["seconds"] for s in runs[b] if "eye seconds" in s and s.get("seconds")]
        if shares:
            print(f"  eye share      {statistics.median(shares):9.3f}  {b}")


if __name__ == "__main__":
    main()
