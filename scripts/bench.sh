#!/usr/bin/env bash
# Raw Embree ray throughput next to the path tracer's, same scene, one run.
#   scripts/bench.sh [SCENE.json] [seconds per measurement]
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/gradphoton ] || scripts/setup.sh
build/gradphoton bench "${1:-scenes/cornell-box.json}" --seconds "${2:-3}"
