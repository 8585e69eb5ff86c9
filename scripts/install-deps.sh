#!/usr/bin/env bash
# Installs what sandmpm needs to build and test, from Debian packages. Idempotent: packages that
# are already installed are not touched, and apt is not called at all when nothing is missing.
set -euo pipefail

# libassimp-dev: mesh files. python3-*: the Python package (cffi in ABI mode, NumPy views) and its
# tests (pytest, run by CTest). gnuplot-nox: the validation study's plots (scripts/validate.sh).
# libopenmpi-dev, openmpi-bin: distributed runs (sandmpm_mpi.h) and their tests under mpirun.
PACKAGES=(cmake make gcc clang libomp-14-dev libc6-dev liblua5.4-dev libpng-dev zlib1g-dev python3 python3-cffi python3-numpy python3-pytest libassimp-dev gnuplot-nox libopenmpi-dev openmpi-bin)

missing=()
for p in "${PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$p")
    fi
done
if [ ${#missing[@]} -eq 0 ]; then
    echo "install-deps: all present (${PACKAGES[*]})"
    exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null; then SUDO="sudo"; else
        echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2
        exit 1
    fi
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
