#!/usr/bin/env bash
# Builds sandmpm (Release, double) if needed and runs `sandmpm run` with the given arguments;
# without arguments that is the built-in default scene, written to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh >/dev/null
cmake -S . -B build-release -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build-release -j "$(nproc 2>/dev/null || echo 2)" -- --no-print-directory >/dev/null
exec build-release/sandmpm run "$@"
