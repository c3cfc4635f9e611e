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
if command -v blender >/dev/null; then
  # The same scene as a .blend for Blender's UI (F12) or `blender -b out/cornell-box.blend -E GRADPHOTON -f 1`.
  blender -b --factory-startup --python scripts/json_to_blend.py -- scenes/cornell-box.json out/cornell-box.blend \
    2>/dev/null | grep -q "json_to_blend: wrote" && echo "demo: Blender scene            at $PWD/out/cornell-box.blend"
fi
