#!/usr/bin/env bash
# Installs what sandmpm needs to build and test, from Debian packages. Idempotent: packages that
# are already installed are not touched, and apt is not called at all when nothing is missing.
set -euo pipefail

# gnuplot-nox and python3-numpy: the validation study (scripts/validate.sh) and its CTest subset.
PACKAGES=(cmake make gcc clang libomp-14-dev libc6-dev liblua5.4-dev libpng-dev gnuplot-nox python3-numpy)

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
