#!/usr/bin/env bash
# The validation study (docs/validation.md): builds Release, runs every simulation and analytic
# benchmark of validation/ (validation/run.py; results in out/validation/full or .../quick), makes
# the plots with gnuplot and writes docs/validation.md from the results (validation/report.py).
#   scripts/validate.sh            the full study (minutes on 2 cores: 77 runs took 163 s at 67e9065; runs already
#                                  done with the same command are reused: rm -rf out/validation to redo)
#   scripts/validate.sh --quick    a coarse subset (minutes); writes out/validation/quick/validation.md
#                                  and leaves docs/ alone
# Not part of scripts/test.sh; its reduced subset is the CTest test test_validation_collapse.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
QUICK=()
[ "${1:-}" = "--quick" ] && QUICK=(--quick)
cmake -S . -B build-release -DCMAKE_BUILD_TYPE=Release -DSM_SIBLING=OFF >/dev/null
cmake --build build-release -j 2 --target sandmpm_cli sm_validate -- --no-print-directory >/dev/null
/usr/bin/python3 validation/run.py "${QUICK[@]}" --bin build-release/sandmpm --analytic build-release/tests/sm_validate
/usr/bin/python3 validation/report.py "${QUICK[@]}"
