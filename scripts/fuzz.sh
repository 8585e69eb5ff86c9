#!/usr/bin/env bash
# Runs the libFuzzer harnesses (docs/robustness.md). Needs clang 14.
#   scripts/fuzz.sh READER [SECONDS]   build build-fuzz, fuzz READER (scene, ply, checkpoint) for SECONDS (default
#                                      900) with the committed corpus as seeds, new inputs in
#                                      build-fuzz/work/READER, crashes in build-fuzz/crash/READER/
#   scripts/fuzz.sh merge READER       add the inputs of build-fuzz/work/READER that reach new
#                                      coverage to tests/fuzz/corpus/READER (libFuzzer -merge=1)
# One fuzzer process, at the lowest priority; ASan and UBSan are on; 2 GB RSS limit, 5 s per input.
# FUZZ_NICE (default 19) and FUZZ_TIMEOUT (seconds per input, default 5) change the last two: on a
# machine busy with builds, a nice-19 fuzzer starves and libFuzzer's wall-clock timeout fires on
# inputs that replay in 0.2 s (docs/robustness.md).
set -euo pipefail
cd "$(dirname "$0")/.."
B=build-fuzz
if [ ! -f $B/CMakeCache.txt ]; then
    cmake -S . -B $B -DCMAKE_C_COMPILER=clang -DSM_FUZZ=ON -DSM_SIBLING=OFF -DSM_OPENMP=OFF -DSM_NATIVE=OFF >/dev/null
fi
if [ "${1:-}" = merge ]; then
    r=$2
    cmake --build $B -j2 --target fuzz_$r >/dev/null
    nice -n 19 $B/tests/fuzz/fuzz_$r -merge=1 -rss_limit_mb=2048 -timeout=5 tests/fuzz/corpus/$r $B/work/$r
    exit 0
fi
r=${1:?usage: scripts/fuzz.sh READER [SECONDS] | merge READER}
secs=${2:-900}
cmake --build $B -j2 --target fuzz_$r >/dev/null
mkdir -p $B/work/$r $B/crash/$r
maxlen=4096
[ "$r" = checkpoint ] && maxlen=32768 # whole checkpoints of the small seed worlds (9-20 KB)
dict=()
[ -f tests/fuzz/$r.dict ] && dict=(-dict=tests/fuzz/$r.dict)
ASAN_OPTIONS=detect_leaks=1 nice -n "${FUZZ_NICE:-19}" $B/tests/fuzz/fuzz_$r "${dict[@]}" -max_total_time="$secs" \
    -rss_limit_mb=2048 -timeout="${FUZZ_TIMEOUT:-5}" -max_len=$maxlen -print_final_stats=1 -artifact_prefix=$B/crash/$r/ \
    $B/work/$r tests/fuzz/corpus/$r
