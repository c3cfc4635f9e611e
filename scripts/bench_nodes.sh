#!/bin/sh
# Node-graph cost (issue 30): pt time per pass on scenes/bench/procedural.json (a principled ground
# whose colour and roughness come from Checker x Noise and a Map Range, a Voronoi ball) against
# the same scene with constant inputs. One thread each, alternated, best of three.
#   scripts/bench_nodes.sh [build-dir] [passes]
set -e
build=${1:-build}
passes=${2:-16}
best() {
  b=""
  for i in 1 2 3; do
    t=$( { /usr/bin/time -f %e "$build/gradphoton" render "$1" --method pt --passes "$passes" --threads 1 \
           -o /tmp/gp_bench_nodes.exr >/dev/null; } 2>&1 | tail -1)
    b=$(python3 -c "print(min(float('$t'), float('${b:-1e9}')))")
  done
  echo "$b"
}
c=$(best scenes/bench/procedural-constants.json)
p=$(best scenes/bench/procedural.json)
python3 -c "c, p, n = $c, $p, $passes; print(f'constants {c / n * 1e3:.1f} ms/pass, procedural {p / n * 1e3:.1f} ms/pass, ratio {p / c:.3f}')"
