#!/usr/bin/env bash
# Same results: proves that a change kept the bits. For the double and the float build it records
#   - tests/same_results: state hashes of eight scenarios (2D/3D, kernels, transfers, colliders of
#     every mode, moving colliders, walls, an emitter, implicit), every 10 steps, 1 and 2 threads;
#   - the printed figures of the physics tests (free fall, incline, collapse, moving colliders,
#     emitters, transfers, seeding, determinism hashes, implicit Newton residuals);
#   - SHA-256 of the frames that `sandmpm run --quality test` writes for the default scene and a
#     few thesis scenes (PLY and VTK files; not diagnostics.csv, which holds wall times);
# into out/same-results/PRECISION.txt and compares it with tests/reference/same-results-PRECISION.txt.
#   scripts/same-results.sh            compare (exit 1 and a diff if anything differs)
#   scripts/same-results.sh --save     store the current results as the reference
#   scripts/same-results.sh --quick    skip the slow tests (implicit world; for a first look)
# The reference belongs to the machine and compiler that made it (CI does not run this): run it
# before a refactor with --save, then after it without.
set -euo pipefail
cd "$(dirname "$0")/.."
SAVE=0
QUICK=0
for a in "$@"; do
    case "$a" in
    --save) SAVE=1 ;;
    --quick) QUICK=1 ;;
    *) echo "usage: scripts/same-results.sh [--save] [--quick]" >&2; exit 2 ;;
    esac
done
bash scripts/install-deps.sh >/dev/null
JOBS=$(nproc 2>/dev/null || echo 2)
mkdir -p out/same-results tests/reference
status=0
for prec in double float; do
    B=build-same-$prec
    flag=OFF
    [ $prec = double ] && flag=ON
    cmake -S . -B "$B" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSM_DOUBLE=$flag -DSM_SIBLING=OFF >/dev/null
    cmake --build "$B" -j "$JOBS" -- --no-print-directory >/dev/null
    res=out/same-results/$prec.txt
    {
        echo "# same_results ($prec)"
        "$B/tests/same_results"
        tests="test_freefall test_incline test_collapse test_moving test_emit test_transfer test_seed test_determinism"
        [ $QUICK -eq 0 ] && tests="$tests test_implicit_world"
        for t in $tests; do
            echo "# $t"
            { "$B/tests/$t" 2>&1 || echo "$t exited with status $?"; } | sed -E 's/: [0-9]+ checks, ([0-9]+) failed/: \1 failed/' # the count of checks may grow
        done
        for scene in default scenes/castle.lua scenes/pile_from_spout.lua scenes/shovel.lua scenes/hourglass.lua; do
            name=$(basename "$scene" .lua)
            dir=out/same-results/run-$prec-$name
            rm -rf "$dir"
            if [ "$scene" = default ]; then
                "$B/sandmpm" run --quality test --out "$dir" >/dev/null 2>&1 || echo "run $name failed"
            else
                "$B/sandmpm" run "$scene" --quality test --frames 2 --out "$dir" >/dev/null 2>&1 || echo "run $name failed"
            fi
            echo "# sandmpm run $name --quality test"
            (cd "$dir" && sha256sum frame_*.ply frame_*.vtp 2>/dev/null || true)
        done
    } >"$res"
    ref=tests/reference/same-results-$prec.txt
    if [ $SAVE -eq 1 ]; then
        cp "$res" "$ref"
        echo "same-results: saved $ref ($(wc -l <"$ref") lines)"
    elif [ ! -f "$ref" ]; then
        echo "same-results: no reference $ref (run with --save first)" >&2
        status=1
    elif [ $QUICK -eq 1 ]; then
        if diff <(awk '/^# test_implicit_world/{skip=1;next} /^# /{skip=0} !skip' "$ref") "$res"; then
            echo "same-results ($prec, quick): identical"
        else
            status=1
        fi
    elif diff "$ref" "$res"; then
        echo "same-results ($prec): identical ($(wc -l <"$res") lines)"
    else
        echo "same-results ($prec): DIFFERENT from $ref" >&2
        status=1
    fi
done
exit $status
