#!/usr/bin/env bash
# Set-up if needed, then render the demo scene (a Cornell box) to an EXR and a PNG.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
mkdir -p out
build/gradphoton render scenes/cornell-box.json --method pt --passes "${DEMO_PASSES:-64}" \
  -o out/cornell-box.exr --png out/cornell-box.png
echo
echo "demo: EXR (every pass a layer) at $PWD/out/cornell-box.exr"
echo "demo: PNG preview              at $PWD/out/cornell-box.png"
