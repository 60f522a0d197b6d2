#!/usr/bin/env bash
# Installs every package the build, the tests and the render tools need on Debian 12.
# Usage: tools/setup-debian.sh [--with-blender]   (runs apt-get; needs root or sudo)
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
PKGS=(cmake g++ make ccache pkg-config clang-14 clang-format-14 libclang-rt-14-dev libassimp-dev
      libopenvdb-dev libboost-iostreams-dev python3-imath
      libeigen3-dev libtbb-dev libblosc-dev
      libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev
      libopenvdb-tools python3 python3-matplotlib python3-dev python3-numpy pybind11-dev
      libopenmpi-dev openmpi-bin)
if [ "${1:-}" = "--with-blender" ]; then PKGS+=(blender); fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${PKGS[@]}" >/dev/null
echo "setup-debian: installed ${#PKGS[@]} packages"
