#!/usr/bin/env bash
# Checkpoints of `sandmpm run` end to end (CTest test_checkpoints: test_checkpoints.sh SANDMPM SRC):
#  - a run killed by SIGKILL at a random moment after its first checkpoint, resumed with another
#    thread count, ends with a last frame byte-identical to an uninterrupted run's;
#  - a corrupted newest checkpoint is reported and the previous one used (same last frame);
#  - a resume with other --set values is refused (exit 2) and --force overrides it;
#  - SIGINT writes a checkpoint of the last frame and prints the resume command; SIGTERM inside a
#    long frame stops at the next step, keeps the last frame, and the resume computes the frame
#    as an uninterrupted run;
#  - only the last K checkpoints are kept;
#  - diagnostics.csv, poses.csv, frames.pvd and run_manifest.txt after a resume equal the
#    uninterrupted run's.
set -u
BIN=$1
SRC=$2
SCENE=$SRC/tests/scenes/ckpt2d.lua
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
export OMP_WAIT_POLICY=PASSIVE
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*" >&2; }
last=frame_0024.ply

"$BIN" run "$SCENE" --out "$TMP/ref" --threads 1 --checkpoint-every 0 >/dev/null 2>&1 || bad "reference run"
[ -f "$TMP/ref/$last" ] && ok || bad "reference run wrote no $last"
[ ! -d "$TMP/ref/checkpoints" ] && ok || bad "--checkpoint-every 0 wrote checkpoints"

# SIGKILL at a random moment once the first checkpoint exists.
"$BIN" run "$SCENE" --out "$TMP/a" --threads 2 --checkpoint-every 3 --keep-checkpoints 2 >/dev/null 2>&1 &
pid=$!
for _ in $(seq 1 400); do
    ls "$TMP"/a/checkpoints/ckpt_*.smc >/dev/null 2>&1 && break
    sleep 0.02
done
sleep "0.$((RANDOM % 5))"
kill -KILL "$pid" 2>/dev/null
wait "$pid" 2>/dev/null
n=$(ls "$TMP"/a/checkpoints/ckpt_*.smc 2>/dev/null | wc -l)
# 1..K, or K + 1 when the kill fell between a new checkpoint's rename and the pruning of the oldest
# (pruning first would leave none for K = 1 if the kill fell before the rename).
[ "$n" -ge 1 ] && [ "$n" -le 3 ] && ok || bad "after SIGKILL: $n checkpoints (want 1..3)"
"$BIN" run "$SCENE" --out "$TMP/a" --threads 3 --checkpoint-every 3 --resume >"$TMP/out" 2>"$TMP/err"
rc=$?
[ "$rc" -eq 0 ] && ok || bad "resume after SIGKILL: exit $rc: $(cat "$TMP/err")"
grep -q "resuming from" "$TMP/err" && ok || bad "resume did not say where from: $(cat "$TMP/err")"
cmp -s "$TMP/a/$last" "$TMP/ref/$last" && ok || bad "resumed last frame differs from the uninterrupted run's"
# Accumulating outputs hold every frame once, as the uninterrupted run's (the wall-time column aside).
cmp -s <(cut -d, -f1-20 "$TMP/a/diagnostics.csv") <(cut -d, -f1-20 "$TMP/ref/diagnostics.csv") && ok ||
    bad "diagnostics.csv after the resume differs: $(diff <(cut -d, -f1-20 "$TMP/a/diagnostics.csv") <(cut -d, -f1-20 "$TMP/ref/diagnostics.csv") | head -5)"
cmp -s "$TMP/a/poses.csv" "$TMP/ref/poses.csv" && ok || bad "poses.csv after the resume differs"
cmp -s "$TMP/a/frames.pvd" "$TMP/ref/frames.pvd" && ok || bad "frames.pvd after the resume differs"
# The run manifest lists every frame of both parts of the run, as the uninterrupted run's does.
cmp -s <(grep -v '^file checkpoints' "$TMP/a/run_manifest.txt") <(grep -v '^file checkpoints' "$TMP/ref/run_manifest.txt") && ok ||
    bad "run_manifest.txt after the resume differs: $(diff "$TMP/a/run_manifest.txt" "$TMP/ref/run_manifest.txt")"
[ "$(ls "$TMP"/a/checkpoints/ckpt_*.smc | wc -l)" -eq 2 ] && ok || bad "not exactly 2 checkpoints kept"
ls "$TMP"/a/checkpoints/.*tmp* >/dev/null 2>&1 && bad "temporaries left in checkpoints/" || ok

# Corrupt the newest checkpoint: reported, the previous one used, same result.
newest=$(ls "$TMP"/a/checkpoints/ckpt_*.smc | sort | tail -1)
printf 'XXXX' | dd of="$newest" bs=1 seek=200 conv=notrunc 2>/dev/null
"$BIN" run "$SCENE" --out "$TMP/a" --threads 1 --checkpoint-every 3 --resume >"$TMP/out" 2>"$TMP/err"
rc=$?
[ "$rc" -eq 0 ] && ok || bad "resume past a corrupt checkpoint: exit $rc"
grep -q "checksum mismatch" "$TMP/err" && ok || bad "corrupt checkpoint not reported: $(cat "$TMP/err")"
grep -q "trying the previous checkpoint" "$TMP/err" && ok || bad "no fall-back reported"
cmp -s "$TMP/a/$last" "$TMP/ref/$last" && ok || bad "last frame after the fall-back differs"

# Truncated newest checkpoint: the same.
newest=$(ls "$TMP"/a/checkpoints/ckpt_*.smc | sort | tail -1)
truncate -s 1000 "$newest"
"$BIN" run "$SCENE" --out "$TMP/a" --threads 1 --checkpoint-every 0 --resume >"$TMP/out" 2>"$TMP/err"
grep -q "truncated\|checksum" "$TMP/err" && ok || bad "truncated checkpoint not reported: $(cat "$TMP/err")"
cmp -s "$TMP/a/$last" "$TMP/ref/$last" && ok || bad "last frame after a truncated checkpoint differs"

# Other parameters: refused, then --force.
"$BIN" run "$SCENE" --out "$TMP/a" --set rate=21 --resume >"$TMP/out" 2>"$TMP/err"
rc=$?
[ "$rc" -eq 2 ] && ok || bad "resume with other --set: exit $rc, want 2"
grep -q "another scene file, --set values" "$TMP/err" && ok || bad "mismatch not explained: $(cat "$TMP/err")"

# SIGINT: the current frame finishes, a checkpoint is written, the resume command printed.
"$BIN" run "$SCENE" --out "$TMP/b" --threads 1 --checkpoint-every 0 >/dev/null 2>"$TMP/err" &
pid=$!
for _ in $(seq 1 400); do
    [ -f "$TMP/b/frame_0002.ply" ] && break
    sleep 0.02
done
kill -INT "$pid"
wait "$pid"
rc=$?
[ "$rc" -ne 0 ] && ok || bad "SIGINT: exit 0"
if grep -q "continue with: sandmpm run" "$TMP/err"; then
    ok
    "$BIN" run "$SCENE" --out "$TMP/b" --threads 2 --checkpoint-every 0 --resume >/dev/null 2>&1
    cmp -s "$TMP/b/$last" "$TMP/ref/$last" && ok || bad "resume after SIGINT: last frame differs"
else
    grep -q "frames 0..24 of 0..24\|^$" "$TMP/err" || bad "SIGINT: no checkpoint reported: $(cat "$TMP/err")"
fi

# SIGTERM inside a long frame (about 100,000 steps) with checkpoints on: the run stops at the next
# step, not after the frame; the checkpoint sink's copy of frame 0 is written and named, frame 1
# is not written, and the resume computes frame 1 as an uninterrupted run does.
long=$TMP/long.lua
cat > "$long" <<'LUA'
return {
  dim = 2, dx = 0.05, ppc = 4, fps = 0.01, frames = 1,
  domain = { min = {0, 0}, max = {1, 1} },
  materials = { sand = { model = "sand", friction_angle = 30 } },
  objects = { { shape = { type = "box", center = {0.5, 0.3}, half_extent = {0.1, 0.1} }, material = "sand" } },
  colliders = { { shape = { type = "halfspace", point = {0, 0.1}, normal = {0, 1} }, mode = "sticky" } },
}
LUA
"$BIN" run "$long" --out "$TMP/l" --threads 1 --checkpoint-every 5 >/dev/null 2>"$TMP/err" &
pid=$!
for _ in $(seq 1 1000); do
    [ -f "$TMP/l/frame_0000.ply" ] || ! kill -0 "$pid" 2>/dev/null && break
    sleep 0.02
done
sleep 0.2 # into frame 1
kill -TERM "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 143 ] && ok || bad "SIGTERM inside a frame: exit $rc, want 143"
grep -qF "SIGTERM: stopping at the next step" "$TMP/err" && ok || bad "SIGTERM inside a frame: no stop message: $(cat "$TMP/err")"
if grep -qF "state at frame 0 kept in $TMP/l/checkpoints/ckpt_00000000.smc" "$TMP/err"; then
    ok
    [ ! -e "$TMP/l/frame_0001.ply" ] && ok || bad "SIGTERM inside a frame: frame 1 written"
    "$BIN" run "$long" --out "$TMP/l-ref" --threads 1 --checkpoint-every 0 >/dev/null 2>&1 || bad "long: reference run"
    "$BIN" run "$long" --out "$TMP/l" --threads 1 --checkpoint-every 5 --resume >/dev/null 2>"$TMP/err" ||
        bad "resume after a stop inside a frame: $(cat "$TMP/err")"
    cmp -s "$TMP/l/frame_0001.ply" "$TMP/l-ref/frame_0001.ply" && ok || bad "resume after a stop inside a frame: frame 1 differs"
else
    bad "SIGTERM inside a frame: frame 0's checkpoint not kept and named: $(cat "$TMP/err")"
fi

# A numerical failure (NaN written into a particle's velocity after frame 10 by the program's test
# hook SANDMPM_TEST_NAN_AT_FRAME, app/run.c): exit code 3, the last good frame's state written as a checkpoint and named,
# and that checkpoint restores (resumed with --force under the parameters without the blow-up).
SANDMPM_TEST_NAN_AT_FRAME=10 "$BIN" run "$SCENE" --out "$TMP/n" --threads 1 --checkpoint-every 20 >/dev/null 2>"$TMP/err"
rc=$?
[ "$rc" -eq 3 ] && ok || bad "numerical failure: exit $rc, want 3: $(cat "$TMP/err")"
grep -q "frame 11 (from t" "$TMP/err" && grep -q "not finite\|non-finite\|NaN" "$TMP/err" && ok || bad "numerical failure: the frame and the NaN not named: $(cat "$TMP/err")"
grep -q "a smaller max_dt" "$TMP/err" && grep -q "elastic_cfl" "$TMP/err" && ok || bad "numerical failure: the scene settings to change not named: $(cat "$TMP/err")"
good=$(sed -n 's/.*the last good state (frame \([0-9]*\)) is in \(.*\)$/\2/p' "$TMP/err")
[ -n "$good" ] && [ -f "$good" ] && ok || bad "no last-good checkpoint reported: $(cat "$TMP/err")"
"$BIN" run "$SCENE" --out "$TMP/n" --threads 1 --checkpoint-every 0 --resume --force >/dev/null 2>"$TMP/err"
rc=$?
[ "$rc" -eq 0 ] && grep -q "resuming from $good" "$TMP/err" && ok || bad "last-good checkpoint does not resume: exit $rc: $(cat "$TMP/err")"

echo "test_checkpoints: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
