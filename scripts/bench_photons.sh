#!/usr/bin/env bash
# Photon tracing rate beside raw Embree, and the SPPM photon pass split into trace, lookup and
# update, one run per hash mode.
#   scripts/bench_photons.sh [SCENE.json] [photons per pass]
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/gradphoton ] || scripts/setup.sh
for hash in exact stochastic; do
  build/gradphoton bench-photons "${1:-scenes/cornell-glass.json}" --photons "${2:-1000000}" --hash "$hash"
  echo
done
