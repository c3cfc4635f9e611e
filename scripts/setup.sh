#!/usr/bin/env bash
# Idempotent set-up on Debian 12: installs the Debian packages gradphoton needs (nothing else
# is downloaded), then configures and builds everything into build/.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  cmake ninja-build g++ pkg-config
  libembree-dev libtbb-dev libopenexr-dev libimath-dev libopencolorio-dev libpng-dev
  pybind11-dev nlohmann-json3-dev libtinyobjloader-dev libeigen3-dev libfftw3-dev
  libcli11-dev libfmt-dev libgtest-dev libbenchmark-dev
  python3-dev python3-numpy python3-matplotlib python3-pytest
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends "${PACKAGES[@]}"
fi

BUILD_TYPE="${GRADPHOTON_BUILD_TYPE:-Release}"
if [ ! -f build/build.ninja ]; then
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE="$BUILD_TYPE"
fi
cmake --build build --parallel "$(nproc)"
