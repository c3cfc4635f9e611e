#!/usr/bin/env bash
# Set-up if needed, then every test: native (GoogleTest through CTest) and Python.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
echo "== native tests (ctest) =="
ctest --test-dir build --output-on-failure --parallel "$(nproc)" --timeout 600
echo "== python tests (pytest, Debian's /usr/bin/python3: the Python Blender embeds) =="
PYTHONPATH="$PWD/build/python" /usr/bin/python3 -m pytest -q tests/python
