#!/usr/bin/env bash
# Set-up if needed, then every test: native (GoogleTest through CTest, with the fuzz corpora
# replayed), a short libFuzzer run of each fuzz target, Python, and the Blender addon inside real
# Blender (background, then its UI under Xvfb).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
echo "== native tests (ctest) =="
ctest --test-dir build --output-on-failure --parallel "$(nproc)" --timeout 600
echo "== fuzz targets, a few seconds each (libFuzzer + ASan/UBSan, build-fuzz/; docs/reliability.md) =="
scripts/fuzz.sh all "${GRADPHOTON_FUZZ_SECONDS:-5}"
echo "== python tests (pytest, Debian's /usr/bin/python3: the Python Blender embeds) =="
PYTHONPATH="$PWD/build/python" /usr/bin/python3 -m pytest -q tests/python
echo "== Blender tests (pytest inside blender -b) =="
blender -b --factory-startup --python tests/blender/run.py
echo "== Blender batch render with the installed addon (blender -b file -E GRADPHOTON -f 1) =="
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
blender -b --factory-startup --python-expr "import bpy; s = bpy.context.scene; s.render.resolution_x, s.render.resolution_y = 32, 24; bpy.ops.wm.save_as_mainfile(filepath='$tmp/default.blend')" >/dev/null
blender -b "$tmp/default.blend" -E GRADPHOTON -o "$tmp/frame_####" -F PNG -f 1 | grep -q "Saved:" || { echo "batch render with the installed addon failed" >&2; exit 1; }
echo "ok"
