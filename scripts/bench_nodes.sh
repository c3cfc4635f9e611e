#!/bin/sh
# Node-graph cost (issue 30): pt time per pass on scenes/bench/procedural.json (a principled ground
# whose colour and roughness come from Checker x Noise and a Map Range, a Voronoi ball) against
# the same scene with constant inputs. One thread each, best of `rounds`, the two scenes (and the
# two builds, given a second) alternated so that a shared machine's load weighs on all alike.
# The time is the path tracer's own ("seconds" of the render's summary): scene loading, the
# albedo/normal/depth passes and the EXR are not in it.
#   scripts/bench_nodes.sh [build-dir] [passes] [rounds] [other-build-dir]
set -e
build=${1:-build}
passes=${2:-16}
rounds=${3:-3}
other=${4:-}
pt_seconds() {
  "$1/gradphoton" render "$2" --method pt --passes "$passes" --threads 1 -o /tmp/gp_bench_nodes.exr 2>&1 |
    awk '$1 == "seconds" { print $2 }'
}
builds="$build${other:+ $other}"
results=""
for r in $(seq "$rounds"); do
  for b in $builds; do
    for s in procedural-constants procedural; do
      results="$results $b:$s:$(pt_seconds "$b" "scenes/bench/$s.json")"
    done
  done
done
python3 - "$passes" $results <<'PY'
import sys
passes = int(sys.argv[1])
best = {}
for item in sys.argv[2:]:
    b, s, t = item.rsplit(":", 2)
    best[(b, s)] = min(best.get((b, s), 1e30), float(t))
for b in dict.fromkeys(k[0] for k in best):
    c, p = best[(b, "procedural-constants")], best[(b, "procedural")]
    print(f"{b}: constants {c / passes * 1e3:.1f} ms/pass, procedural {p / passes * 1e3:.1f} ms/pass, "
          f"ratio {p / c:.3f}")
PY
