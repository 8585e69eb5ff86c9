#!/usr/bin/env bash
# Builds the Release program (sandmpm, and next to it the other precision's program, CMake
# SM_SIBLING) and runs `sandmpm bench`: a block of sand collapsing onto a sticky ground (hardening,
# quadratic kernel, APIC, explicit, all stages), 2D and 3D, float and double, 1 and 2 threads,
# about a million particles per case. Extra arguments go to `sandmpm bench` (e.g. --particles
# 250000, --dim 3, --threads 1,2,4, --csv). The output is also saved in out/bench/ (DATE.txt with
# the machine, compiler and commit on top, or DATE.csv with --csv).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh >/dev/null
B=build-bench
cmake -S . -B "$B" -DCMAKE_BUILD_TYPE=Release -DSM_SIBLING=ON >/dev/null
cmake --build "$B" -j "$(nproc 2>/dev/null || echo 2)" --target sandmpm_programs -- --no-print-directory >/dev/null

csv=0
for a in "$@"; do [ "$a" = --csv ] && csv=1; done
mkdir -p out/bench
stamp=$(date +%Y%m%d-%H%M%S)
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD 2>/dev/null || commit="$commit (with uncommitted changes)"
machine() {
    echo "# $(date -Iseconds), commit $commit"
    echo "# $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1), $(nproc) cores," \
         "$(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo)"
    echo "# $(sed -n 's/^CMAKE_C_COMPILER:[A-Z]*=//p' "$B/CMakeCache.txt") ($("$(sed -n 's/^CMAKE_C_COMPILER:[A-Z]*=//p' "$B/CMakeCache.txt")" --version | head -1)), Release," \
         "SM_NATIVE=$(sed -n 's/^SM_NATIVE:BOOL=//p' "$B/CMakeCache.txt"); $("$B/sandmpm" --version)"
}
if [ $csv -eq 1 ]; then
    machine >&2
    "$B/sandmpm" bench "$@" | tee "out/bench/$stamp.csv"
    echo "scripts/bench.sh: saved out/bench/$stamp.csv" >&2
else
    machine | tee "out/bench/$stamp.txt"
    "$B/sandmpm" bench "$@" | tee -a "out/bench/$stamp.txt"
    echo "scripts/bench.sh: saved out/bench/$stamp.txt" >&2
fi
