#!/usr/bin/env bash
# Installs every Debian 12 package the build, the programs and the tests use.
# Idempotent: packages already present are left alone; safe to run again.
# Must run as root (or through sudo) on Debian 12 (bookworm).
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang libclang-rt-14-dev clang-format
  # a compiler cache: the three configurations of scripts/test.sh rebuild little between runs
  ccache
  # OpenGL: libepoxy for entry points, Mesa for EGL (surfaceless) and GLX on llvmpipe
  libepoxy-dev libegl-dev libegl-mesa0 libgl1 libglx-mesa0 libgl1-mesa-dri
  # windowing and UI
  libglfw3-dev libimgui-dev libstb-dev libfreetype-dev xvfb xauth
  # the panel's font (DejaVu Sans: arrows, ×, ², … beyond ImGui's ASCII font)
  fonts-dejavu-core
  # the viewer's tests: real mouse and keys under Xvfb
  xdotool
  # maths, geodesy, geometry, geodata, images, json
  libglm-dev libgeographiclib-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libgdal-dev gdal-bin libopenimageio-dev openimageio-tools nlohmann-json3-dev
  # the caches' checksums (XXH3, header-only use: XXH_INLINE_ALL)
  libxxhash-dev
  # the national-border scene of scripts/border_scene.sh: GMT and the Digital Chart of the World
  gmt gmt-dcw
  # its --coast layer: GMT's full-resolution GSHHG shorelines
  gmt-gshhg-full
  # the globe scene of scripts/globe_scene.sh: GSHHG's crude, low and intermediate shorelines for
  # the DEM's land/sea mask, and PROJ's grids for EGM96 (egm96_15.gtx) for its ellipsoidal heights
  gmt-gshhg-low proj-data
  # tests; a real PostgreSQL + PostGIS server for the PostGIS source test (tests/geo/with_postgis.sh)
  libgtest-dev libgmock-dev postgresql postgresql-15-postgis-3
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
