#!/usr/bin/env bash
# Writes seed inputs for fuzz_checkpoint into OUTDIR from real checkpoints: for each program
# given (e.g. the float and the double build's sandmpm) a 2D (tests/fuzz/ckpt_seed2d.lua) and a
# 3D (tests/scenes/valid3d.lua at dx 0.06) run of a few frames; of each run's newest checkpoint
#   stream_NAME.bin = 0x00 + the library stream (the file without its 28-byte trailer),
#   file_NAME.bin   = 0x01 + the whole checkpoint file.
# Usage: tests/fuzz/make_checkpoint_seeds.sh OUTDIR SANDMPM...
# The checkpoint format changed (a new CKPT_VERSION)? Remove the old stream_/file_ seeds, run
# this, then `scripts/fuzz.sh merge checkpoint`.
set -euo pipefail
out=$1
shift
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
for prog in "$@"; do
    case "$("$prog" -V)" in *double*) prec=double ;; *) prec=float ;; esac
    for dim in 2 3; do
        if [ $dim = 2 ]; then
            "$prog" run tests/fuzz/ckpt_seed2d.lua --out "$tmp/$prec$dim" --checkpoint-every 1 --threads 1 >/dev/null
        else
            "$prog" run tests/scenes/valid3d.lua --set dx=0.06 --end 0.1 --out "$tmp/$prec$dim" --checkpoint-every 1 \
                --threads 1 >/dev/null
        fi
        ck=$(ls "$tmp/$prec$dim"/checkpoints/*.smc | sort | tail -n 1)
        size=$(stat -c %s "$ck")
        { printf '\000'; head -c $((size - 28)) "$ck"; } >"$out/stream_${prec}_ck$dim.bin"
        { printf '\001'; cat "$ck"; } >"$out/file_${prec}_ck$dim.bin"
        echo "$out: ${prec} ${dim}D from $ck ($size bytes)"
    done
done
