#!/usr/bin/env bash
# Rendered-viewport benchmark (scripts/bench_viewport.py) on the demo scene and on the
# 1 M-triangle scene, in Blender's window under Xvfb. Prints one JSON line per scene.
set -euo pipefail
cd "$(dirname "$0")/.."
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
for name in ${GRADPHOTON_BENCH_SCENES:-cornell-box cornell-dense}; do
  blender -b --factory-startup --python scripts/json_to_blend.py -- "scenes/$name.json" "$tmp/$name.blend" >/dev/null 2>&1
  xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup "$tmp/$name.blend" \
    --python scripts/bench_viewport.py -- "$@" 2>&1 | grep '^BENCH_VIEWPORT' | sed "s/^BENCH_VIEWPORT /$name /"
done
