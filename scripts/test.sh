#!/usr/bin/env bash
# The project's test command (README): installs dependencies, then builds and runs every test in
# the double and the float build, warnings as errors with gcc, a clang build (warnings as errors),
# and an AddressSanitizer + UndefinedBehaviorSanitizer build.
#   scripts/test.sh            all of the above
#   scripts/test.sh --quick    the double build only
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh

JOBS=$(nproc 2>/dev/null || echo 2)
QUICK=0
[ "${1:-}" = "--quick" ] && QUICK=1

run_build() { # name, cmake args...
    local name=$1; shift
    echo "=== build-$name: $*"
    cmake -S . -B "build-$name" -DSM_WERROR=ON "$@" >/dev/null
    cmake --build "build-$name" -j "$JOBS" -- --no-print-directory >/dev/null
    (cd "build-$name" && ctest --output-on-failure -j 1)
}

run_build double -DSM_DOUBLE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo
if [ $QUICK -eq 0 ]; then
    run_build float -DSM_DOUBLE=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo
    run_build clang -DSM_DOUBLE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DSM_SIBLING=OFF
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
        run_build asan -DSM_DOUBLE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSM_SANITIZE=ON -DSM_SIBLING=OFF
fi
echo "scripts/test.sh: all builds passed"
