#!/usr/bin/env bash
# Builds the float and the double Release builds and runs sm_bench in each (3D sand block,
# about 250k particles, hardening, quadratic, APIC; 1 and 2 threads). Extra arguments go to sm_bench.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh >/dev/null
J=$(nproc 2>/dev/null || echo 2)
for p in double float; do
    opt=ON; [ $p = float ] && opt=OFF
    cmake -S . -B "build-bench-$p" -DCMAKE_BUILD_TYPE=Release -DSM_DOUBLE=$opt >/dev/null
    cmake --build "build-bench-$p" -j "$J" --target sm_bench -- --no-print-directory >/dev/null
    "build-bench-$p/bench/sm_bench" "$@"
done
