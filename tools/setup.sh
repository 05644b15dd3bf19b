#!/usr/bin/env bash
# Installs polyhex's Debian 12 dependencies (only what is missing) and builds it in ./build.
#   tools/setup.sh            install + configure + build (Release)
# Environment: BUILD_DIR (default build), JOBS (default: number of cores).
set -euo pipefail
cd "$(dirname "$0")/.."
PACKAGES=(build-essential cmake ccache libeigen3-dev libtbb-dev libsuitesparse-dev nlohmann-json3-dev libopenvdb-dev
          libboost-iostreams-dev catch2 libtet1.5-dev libcli11-dev libspdlog-dev libopenblas0-pthread
          python3-numpy python3-scipy clang libclang-rt-14-dev clang-format
          libcgal-dev libgmp-dev libmpfr-dev                                  # surface conditioning (CGAL)
          libexodusii-dev libnetcdf-dev python3-meshio python3-netcdf4 gmsh   # Exodus II writer, solver-format clients
          libjs-three chromium fonts-dejavu-core zlib1g-dev)  # the HTML report (three.js inlined) and its browser test
missing=()
for p in "${PACKAGES[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  echo "polyhex setup: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-$(nproc)}
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS"
echo "polyhex setup: built $BUILD_DIR/polyhex"
