#!/usr/bin/env bash
# Installs the Debian 12 packages horizon needs to build, test and render
# headless. Installs only what is missing; safe to run repeatedly.
set -euo pipefail
PKGS=(
  build-essential cmake pkg-config
  libcglm-dev          # vectors, matrices, frustum planes
  libepoxy-dev         # GL/EGL function loading
  libegl-dev libegl1-mesa-dev libgl1-mesa-dri libegl-mesa0   # EGL + Mesa llvmpipe (software GL 4.5)
  libstb-dev           # stb_image / stb_image_write
  libpng-dev zlib1g-dev
  libzstd-dev libxxhash-dev  # terrain pyramids: tile compression and checksums
  libjansson-dev       # JSON written by the commands
  parallel             # make test: pyramid import jobs run side by side
  libgdal-dev          # DEM reading (GeoTIFF, SRTM, ENVI, ASCII grid, VRT), mosaics, reprojection (PROJ)
  gdal-bin             # tests make georeferenced rasters (gdal_translate, gdalwarp, gdaltransform)
  libcmocka-dev        # unit tests
  python3              # CLI tests check JSON output
  libglfw3-dev libglx-mesa0   # horizon view: GLFW window, GLX on Mesa llvmpipe
  xvfb                 # horizon view tests run in a virtual X server (scripts/with-xvfb.sh)
  libmeshoptimizer-dev # crown hull simplification
  libassimp-dev        # tree import (OBJ, glTF, ...)
  libjansson-dev       # JSON output (escaped, valid whatever the file names), CityJSON and scene files
  libinih-dev          # horizon view --config files
  clang libclang-rt-14-dev  # make test: the ASan/UBSan build (build-san/) and the libFuzzer targets (build-fuzz/)
  libcurl4-openssl-dev nginx  # --terrain http(s)://...: range requests (libcurl); tests serve pyramids with nginx
)
# "bench": also gnuplot for horizon bench --plot
if [ "${1:-}" = bench ]; then PKGS+=(gnuplot-nox); fi
# "docs": Doxygen for make docs
if [ "${1:-}" = docs ]; then PKGS+=(doxygen); fi
missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "deps: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null; then SUDO=sudo; else
    echo "deps: missing packages (${missing[*]}) and not root; install them with apt-get" >&2
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q >&2
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
