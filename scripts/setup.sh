#!/usr/bin/env bash
# Idempotent set-up on Debian 12: installs the Debian packages gradphoton needs (nothing else
# is downloaded), configures and builds everything into build/, then installs the Blender
# addon (a link to addon/gradphoton in Blender's user addon folder) and enables it.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  cmake ninja-build g++ pkg-config
  libembree-dev libtbb-dev libopenexr-dev libimath-dev libopencolorio-dev libopenimageio-dev libpng-dev
  libopenvdb-dev libblosc-dev
  pybind11-dev nlohmann-json3-dev libtinyobjloader-dev libeigen3-dev libfftw3-dev
  libcli11-dev libfmt-dev libgtest-dev libbenchmark-dev
  python3-dev python3-numpy python3-matplotlib python3-pytest python3-hypothesis
  clang libclang-rt-14-dev
  blender xvfb xauth xdotool libgl1-mesa-dri
  slurm-wlm munge
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

# ---- Blender addon: link addon/gradphoton into the user addon folder and enable it ----
# (Set GRADPHOTON_SKIP_ADDON=1 to leave Blender's configuration alone.)
if [ "${GRADPHOTON_SKIP_ADDON:-0}" != 1 ] && command -v blender >/dev/null; then
  ADDONS="$(blender -b --factory-startup --python-expr \
    "import bpy; print('ADDONS=' + bpy.utils.user_resource('SCRIPTS', path='addons', create=True))" 2>/dev/null \
    | sed -n 's/^ADDONS=//p')"
  if [ -n "$ADDONS" ]; then
    mkdir -p "$ADDONS"
    target="$ADDONS/gradphoton"
    if [ -e "$target" ] && [ ! -L "$target" ]; then rm -rf "$target"; fi
    ln -sfn "$PWD/addon/gradphoton" "$target"
    # Without --factory-startup: keep the user's preferences, add the addon, save them.
    blender -b --python-expr "
import addon_utils, bpy, sys
loaded, enabled = addon_utils.check('gradphoton')
if not enabled:
    addon_utils.enable('gradphoton', default_set=True, handle_error=lambda e: sys.exit(1))
    bpy.ops.wm.save_userpref()
print('GRADPHOTON_ADDON=enabled')
" 2>&1 | grep -q GRADPHOTON_ADDON=enabled || { echo "setup: enabling the Blender addon failed" >&2; exit 1; }
    echo "setup: Blender addon linked at $target and enabled"
  fi
fi
