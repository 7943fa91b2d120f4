#!/usr/bin/env bash
# Installs the Debian/Ubuntu packages potmap needs (only those missing), then configures and
# builds potmap in ./build (Release). Safe to run again: it does nothing that is already done.
# Extra arguments are passed to the cmake configure step (e.g. -DPOTMAP_BUILD_BENCH=OFF).
# POTMAP_BUILD_TARGET: build only this target (e.g. potmap_cli, the command; default: all).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

packages=(
  build-essential cmake pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers clinfo
  libboost-dev libeigen3-dev libcli11-dev nlohmann-json3-dev
  libzip-dev libpng-dev zlib1g-dev
  libsqlite3-dev libyaml-cpp-dev libzstd-dev zstd libfastcdr-dev
  liboctomap-dev libpcl-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libgdal-dev libopenmpi-dev openmpi-bin
  librosbag-storage-dev libtf2-dev libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev
  libtf2-msgs-dev python3-rosbag python3-sensor-msgs python3-tf2-msgs python3-nav-msgs
  python3-geometry-msgs
  python3 python3-numpy
  python3-dev pybind11-dev python3-pytest python3-matplotlib
  python3-setuptools python3-wheel python3-venv python3-pip
  clang libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo=()
  if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
    sudo=(sudo)
  fi
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
else
  echo "setup: all ${#packages[@]} packages present"
fi

jobs=$(nproc)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build build -j"$jobs" ${POTMAP_BUILD_TARGET:+--target "$POTMAP_BUILD_TARGET"}
