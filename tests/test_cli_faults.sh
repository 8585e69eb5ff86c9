# Sourced by tests/test_cli.sh (PART faults; its helpers expect, has, ok, bad and BIN, SRC, TMP).
# Hostile and careless input to the command line, and disk trouble (issue 12, items 7 and 8):
#   - a folder or scene named x';touch INJECTED;' with --video (run and render): no command runs,
#     ffmpeg gets the name as one argument (a stand-in ffmpeg records its arguments), a missing
#     ffmpeg is said so;
#   - --end 1e10 (too many frames), an --end shorter than a frame, --out "", paths too long for the
#     files written into them, a name component too long: exit 2 or 4 with the reason;
#   - SIGINT / SIGTERM: whole files only, no temporaries, the frames complete named, exit 130 /
#     143; a second SIGINT stops at once, still without temporaries; after SIGKILL the next run
#     removes the temporaries of dead processes (and only those);
#   - a full disk (SANDMPM_FAULT_WRITE_BYTES, and a 64 KiB tmpfs where mount works): exit 4 with
#     the file and "No space left on device", no temporary, no file under its final name cut
#     short, diagnostics.csv and poses.csv whole lines only; an unwritable folder, a file where the
#     folder or poses.csv should be: exit 4 with the path and the reason; stdout on a full device;
#   - huge velocities: the library's message with the frame and the times;
#   - colliders in `run --render` drawn where they are at each frame (as `render` draws them);
#   - `render` finds frames past 9999 (frame_10000.ply).

# A tiny 2D scene: 64 particles on a sticky ground; params v (their speed), cv (the ground's), bv
# (a box collider's speed), fps, vtk.
tiny=$TMP/tiny.lua
cat > "$tiny" <<'EOF'
return {
  dim = 2, dx = 0.05, ppc = 4, fps = params.fps or 24, frames = 2,
  domain = { min = {0, 0}, max = {1, 1} },
  materials = { sand = { model = "sand", friction_angle = 30 } },
  objects = { { shape = { type = "box", center = {0.5, 0.3}, half_extent = {0.1, 0.1} }, material = "sand",
                velocity = { params.v or 0, 0 } } },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.1}, normal = {0, 1} }, mode = "sticky", velocity = { params.cv or 0, 0 } },
    { shape = { type = "box", center = {0.2, 0.6}, half_extent = {0.05, 0.05} }, mode = "slip", velocity = { params.bv or 0, 0 } },
  },
  outputs = { vtk = params.vtk ~= false },
}
EOF

no_temporaries() { # dir description
    local t
    t=$(find "$1" -name '*.tmp*' 2>/dev/null | head -3)
    [ -z "$t" ] && ok || bad "$2: temporaries left: $t"
}

# Every file under its final name is whole: PLY size = header + 46 bytes per vertex; VTK files
# end with </VTKFile>; CSV lines complete (13 and 9 fields, a final newline).
whole_files() { # dir description
    local d=$1 f n h size
    for f in "$d"/frame_*.ply; do
        [ -e "$f" ] || continue
        n=$(sed -n 's/^element vertex //p' "$f" | head -1 | tr -d '\r')
        h=$(grep -abo 'end_header' "$f" | head -1 | cut -d: -f1)
        size=$(wc -c < "$f")
        [ -n "$n" ] && [ -n "$h" ] && [ "$size" -eq $((h + 11 + 46 * n)) ] && ok || bad "$2: $f is cut short ($size bytes)"
    done
    for f in "$d"/frame_*.vtp "$d"/frames.pvd; do
        [ -e "$f" ] || continue
        [ "$(tail -c 11 "$f")" = "</VTKFile>" ] && ok || bad "$2: $f is cut short"
    done
    for f in "$d"/diagnostics.csv "$d"/poses.csv; do
        [ -s "$f" ] || continue
        [ -z "$(tail -c 1 "$f")" ] && ok || bad "$2: $f ends inside a line"
    done
    [ -s "$d/diagnostics.csv" ] && { awk -F, 'NF != 22 { b = 1 } END { exit b }' "$d/diagnostics.csv" && ok || bad "$2: diagnostics.csv has a partial line"; }
    [ -s "$d/poses.csv" ] && { awk -F, 'NF != 9 { b = 1 } END { exit b }' "$d/poses.csv" && ok || bad "$2: poses.csv has a partial line"; }
    return 0
}

# --- Shell command injection through --video -------------------------------------------------
mkdir -p "$TMP/bin" "$TMP/inj"
cat > "$TMP/bin/ffmpeg" <<'EOF'
#!/bin/sh
# A stand-in for ffmpeg: its arguments, one a line, to $FAKE_FFMPEG_LOG; the last (the output) written.
for a in "$@"; do printf '%s\n' "$a"; done > "$FAKE_FFMPEG_LOG"
out=; for a in "$@"; do out=$a; done
printf 'not a video\n' > "$out"
exit "${FAKE_FFMPEG_EXIT:-0}"
EOF
chmod +x "$TMP/bin/ffmpeg"
evil="x';touch INJECTED;'"
cp "$tiny" "$TMP/inj/$evil.lua"
(cd "$TMP/inj" && PATH="$TMP/bin:$PATH" FAKE_FFMPEG_LOG="$TMP/ffmpeg.args" "$BIN" run "$evil.lua" --frames 1 --render --video \
    >"$TMP/out" 2>"$TMP/err")
got=$?
[ $got -eq 0 ] && ok || bad "run --video into out/$evil: exit $got: $(cat "$TMP/err")"
[ -z "$(find "$TMP" -name INJECTED)" ] && ok || bad "run --video: the folder name ran a command"
[ -s "$TMP/inj/out/$evil/video.mp4" ] && ok || bad "run --video: no video.mp4 in out/$evil"
grep -qxF -- "$(cd "$TMP/inj" && pwd -P)/out/$evil/frame_%04d.png" "$TMP/ffmpeg.args" && ok ||
    bad "ffmpeg did not get the frames' pattern as one argument: $(cat "$TMP/ffmpeg.args")"
no_temporaries "$TMP/inj/out" "run --video"
(cd "$TMP/inj" && PATH="$TMP/bin:$PATH" FAKE_FFMPEG_EXIT=1 FAKE_FFMPEG_LOG="$TMP/ffmpeg.args" "$BIN" render "out/$evil" \
    --size 32x24 --video >"$TMP/out" 2>"$TMP/err")
got=$?
[ $got -eq 4 ] && ok || bad "render --video with a failing ffmpeg: exit $got, expected 4"
has "$TMP/err" "ffmpeg failed (exit status 1)" "ffmpeg's failure reported"
[ -z "$(find "$TMP" -name INJECTED)" ] && ok || bad "render --video: the folder name ran a command"
no_temporaries "$TMP/inj/out" "render --video, ffmpeg failing"
# without the stand-in: the real ffmpeg if installed, else a message saying it is missing
(cd "$TMP/inj" && "$BIN" render "out/$evil" --size 32x24 --video >"$TMP/out" 2>"$TMP/err")
got=$?
if command -v ffmpeg >/dev/null 2>&1; then
    [ $got -eq 0 ] && ok || bad "render --video with ffmpeg installed: exit $got: $(cat "$TMP/err")"
else
    [ $got -eq 4 ] && ok || bad "render --video without ffmpeg: exit $got, expected 4"
    has "$TMP/err" "ffmpeg is not installed" "missing ffmpeg named"
fi
[ -z "$(find "$TMP" -name INJECTED)" ] && ok || bad "render --video: the folder name ran a command"

# --- Frame counts and paths -----------------------------------------------------------------
expect 2 "--end 1e10" "$BIN" run "$tiny" --end 1e10 --set vtk=false --out "$TMP/never"
has "$TMP/err" "240000000000 frames" "--end 1e10: the frame count named"
expect 2 "--end 1e10 with VTK" "$BIN" run "$tiny" --end 1e10 --out "$TMP/never"
expect 2 "--end shorter than a frame" "$BIN" run "$tiny" --end 1e-300 --out "$TMP/never"
has "$TMP/err" "less than one frame" "--end 1e-300 explained"
expect 2 "--out \"\"" "$BIN" run "$tiny" --out ""
has "$TMP/err" "name is empty" "--out \"\" explained"
[ ! -e "$TMP/never" ] && ok || bad "an output folder was created for a refused run"
long=$TMP/long
while [ ${#long} -lt 4040 ]; do long="$long/$(printf 'c%.0s' $(seq 1 100))"; done
expect 2 "a path too long for its files" "$BIN" run "$tiny" --frames 1 --out "$long"
has "$TMP/err" "bytes" "long path: its length named"
expect 2 "render of a path too long" "$BIN" render "$long"
[ ! -e "$TMP/long" ] && ok || bad "long path: folders created"
expect 4 "a name component too long" "$BIN" run "$tiny" --frames 1 --out "$TMP/$(printf 'n%.0s' $(seq 1 300))"
has "$TMP/err" "File name too long" "long component: the reason kept"

# --- Signals ----------------------------------------------------------------------------------
wait_for() { # file seconds: wait until the file exists
    local i=0
    while [ ! -e "$1" ] && [ $i -lt $(($2 * 10)) ]; do sleep 0.1; i=$((i + 1)); done
}
for sig in INT TERM; do
    d=$TMP/sig_$sig
    "$BIN" run "$tiny" --frames 100000 --out "$d" >/dev/null 2>"$TMP/err_$sig" &
    p=$!
    wait_for "$d/frame_0001.ply" 60
    kill -$sig $p
    wait $p
    got=$?
    want=$([ $sig = INT ] && echo 130 || echo 143)
    [ $got -eq $want ] && ok || bad "SIG$sig: exit $got, expected $want: $(cat "$TMP/err_$sig")"
    has "$TMP/err_$sig" "stopped by SIG$sig after frame" "SIG$sig: the last frame named"
    no_temporaries "$d" "SIG$sig"
    whole_files "$d" "SIG$sig"
    last=$(sed -n 's/.*stopped by SIG[A-Z]* after frame \([0-9]*\).*/\1/p' "$TMP/err_$sig")
    [ -n "$last" ] && [ "$(ls "$d" | grep -c '^frame_.*\.ply$')" -eq $((last + 1)) ] && ok ||
        bad "SIG$sig: says frame $last is the last, the folder has $(ls "$d" | grep -c '^frame_.*\.ply$') PLY frames"
    [ -n "$last" ] && [ "$(wc -l < "$d/diagnostics.csv")" -eq $((last + 2)) ] && ok || bad "SIG$sig: diagnostics.csv rows"
    [ -n "$last" ] && grep -qx "frame_files ply 0 $last" "$d/run_manifest.txt" && grep -qx "state stopped" "$d/run_manifest.txt" &&
        ok || bad "SIG$sig: the run manifest after frame $last: $(cat "$d/run_manifest.txt")"
done
d=$TMP/sig_twice # frames of 50 s (50,000 steps): the second SIGINT comes during one (at 10 s a
# frame, one thread did the 10,000 steps of 64 particles within the 0.3 s between the signals);
# without checkpoints the first SIGINT waits for the frame (with them it stops at the next step)
"$BIN" run "$tiny" --set fps=0.02 --frames 1000 --checkpoint-every 0 --out "$d" >/dev/null 2>"$TMP/err" &
p=$!
wait_for "$d/frame_0000.ply" 60
kill -INT $p; sleep 0.3; kill -INT $p
wait $p
got=$?
[ $got -eq 130 ] && ok || bad "SIGINT twice: exit $got, expected 130"
has "$TMP/err" "stopped at once; frames 0..0 are complete in $d/" "SIGINT twice: what is complete"
no_temporaries "$d" "SIGINT twice"
whole_files "$d" "SIGINT twice"
# SIGKILL at random moments: whatever it leaves, the next run in the folder removes the
# temporaries of dead processes; a live process's temporary (this shell's pid) is kept.
d=$TMP/killed
for i in 1 2 3; do
    "$BIN" run "$tiny" --frames 100000 --out "$d" >/dev/null 2>&1 &
    p=$!
    wait_for "$d/frame_0000.ply" 60
    sleep "0.$((RANDOM % 10))"
    kill -KILL $p
    wait $p 2>/dev/null
done
# the manifest lists frames that are on disk (the frame after them may be written, not yet listed)
listed=$(sed -n 's/^frame_files ply 0 \([0-9]*\)$/\1/p' "$d/run_manifest.txt")
ondisk=$(ls "$d" | grep -c '^frame_.*\.ply$')
[ -n "$listed" ] && [ -f "$d/$(printf 'frame_%04d.ply' "$listed")" ] && [ "$ondisk" -le $((listed + 2)) ] && ok ||
    bad "after SIGKILL: the manifest lists frames 0..$listed, $ondisk PLY files on disk"
sh -c 'exit 0' & dead=$!
wait $dead
mkdir -p "$d/checkpoints"
touch "$d/.frame_0007.ply.tmp.$dead" "$d/.frames.pvd.tmp.$dead" "$d/.frame_0008.ply.tmp.$$" "$d/frame_0009.vtp.tmp" \
    "$d/checkpoints/.ckpt_00000160.smc.tmp.$dead"
expect 0 "a run after SIGKILLs" "$BIN" run "$tiny" --frames 1 --out "$d"
has "$TMP/err" "removed" "stale temporaries: said so"
[ -z "$(find "$d" -name '*.tmp*' ! -name ".frame_0008.ply.tmp.$$")" ] && ok ||
    bad "stale temporaries left: $(find "$d" -name '*.tmp*')"
[ -e "$d/.frame_0008.ply.tmp.$$" ] && ok || bad "a live process's temporary was removed"
rm -f "$d/.frame_0008.ply.tmp.$$"

# --- Disk trouble -----------------------------------------------------------------------------
for n in 0 4000 9000 20000; do
    d=$TMP/full_$n
    SANDMPM_FAULT_WRITE_BYTES=$n "$BIN" run "$tiny" --frames 3 --out "$d" >/dev/null 2>"$TMP/err"
    got=$?
    [ $got -eq 4 ] && ok || bad "full disk ($n bytes): exit $got, expected 4: $(cat "$TMP/err")"
    has "$TMP/err" "No space left on device" "full disk ($n bytes): the reason"
    has "$TMP/err" "$d/" "full disk ($n bytes): the file"
    no_temporaries "$d" "full disk ($n bytes)"
    whole_files "$d" "full disk ($n bytes)"
    [ ! -e "$d/diagnostics.csv" ] || [ "$(wc -l < "$d/diagnostics.csv")" -ge 2 ] && ok ||
        bad "full disk ($n bytes): diagnostics.csv without a row"
done
mnt=$TMP/tmpfs
mkdir -p "$mnt"
if [ "$(id -u)" = 0 ] && mount -t tmpfs -o size=64k tmpfs "$mnt" 2>/dev/null; then
    "$BIN" run "$tiny" --frames 50 --out "$mnt/run" >/dev/null 2>"$TMP/err"
    got=$?
    [ $got -eq 4 ] && ok || bad "64 KiB tmpfs: exit $got, expected 4"
    has "$TMP/err" "No space left on device" "64 KiB tmpfs: the reason"
    no_temporaries "$mnt/run" "64 KiB tmpfs"
    whole_files "$mnt/run" "64 KiB tmpfs"
    umount "$mnt"
else
    echo "test_cli: no tmpfs (not root, or mount not allowed); full disk tested by SANDMPM_FAULT_WRITE_BYTES only"
fi
touch "$TMP/afile"
expect 4 "--out is a file" "$BIN" run "$tiny" --frames 1 --out "$TMP/afile"
has "$TMP/err" "not a folder" "--out is a file: said so"
expect 4 "--out under a file" "$BIN" run "$tiny" --frames 1 --out "$TMP/afile/run"
has "$TMP/err" "Not a directory" "--out under a file: the reason"
mkdir -p "$TMP/pz/poses.csv"
expect 4 "poses.csv cannot be opened" "$BIN" run "$tiny" --frames 1 --out "$TMP/pz"
has "$TMP/err" "poses.csv" "poses.csv named"
ro=$TMP/ro
mkdir -p "$ro/out" && cp "$tiny" "$ro/tiny.lua" && chmod 755 "$TMP" "$ro" && chmod 644 "$ro/tiny.lua" && chmod 555 "$ro/out"
as_user=
[ "$(id -u)" = 0 ] && command -v setpriv >/dev/null && as_user="setpriv --reuid=nobody --regid=nogroup --clear-groups"
if [ "$(id -u)" != 0 ] || [ -n "$as_user" ]; then
    expect 4 "an unwritable folder" $as_user "$BIN" run "$ro/tiny.lua" --frames 1 --out "$ro/out"
    has "$TMP/err" "Permission denied" "unwritable folder: the reason"
    has "$TMP/err" "$ro/out/" "unwritable folder: the path"
else
    echo "test_cli: root without setpriv: the unwritable folder is not tested"
fi
chmod 700 "$TMP"

# Standard output that cannot be written is an I/O failure too.
if [ -w /dev/full ]; then
    expect 4 "info > /dev/full" sh -c '"$0" info "$1" >/dev/full' "$BIN" "$tiny"
    has "$TMP/err" "No space left on device" "info > /dev/full: the reason"
    expect 4 "--help > /dev/full" sh -c '"$0" --help >/dev/full' "$BIN"
fi

# --- Huge velocities: the loader's estimate refuses the run before it starts (a speed of 1e300 m/s
# needs more time steps than any run can take); the library's own message for an overflow inside a
# step is tested in test_api.c ---
"$BIN" run "$tiny" --set v=1e300 --frames 2 --out "$TMP/fast" >/dev/null 2>"$TMP/err"
got=$?
[ $got -ne 0 ] && [ $got -ne 1 ] && ok || bad "huge velocity: exit $got"
has "$TMP/err" "the run cannot finish" "huge velocity: the loader's estimate"
has "$TMP/err" "objects[1]" "huge velocity: which object"
[ ! -e "$TMP/fast/frame_0000.ply" ] && ok || bad "huge velocity: a frame was written"

# --- Colliders drawn where they are at each frame, during the run as by `render` -----------------
expect 0 "run --render with a moving box" "$BIN" run "$tiny" --set bv=2 --frames 2 --render --out "$TMP/mov"
cp -r "$TMP/mov" "$TMP/mov2" && rm "$TMP/mov2"/*.png
expect 0 "render of the moving box" "$BIN" render "$TMP/mov2"
cmp -s "$TMP/mov/frame_0002.png" "$TMP/mov2/frame_0002.png" && ok || bad "run --render and render draw frame 2 differently"
cmp -s "$TMP/mov/frame_0000.png" "$TMP/mov/frame_0002.png" && bad "the box did not move in the pictures" || ok

# --- render finds frames past 9999 ---------------------------------------------------------------
mkdir -p "$TMP/many" && cp "$TMP/mov/render.txt" "$TMP/mov/frame_0000.ply" "$TMP/many/" &&
    cp "$TMP/mov/frame_0000.ply" "$TMP/many/frame_10000.ply" && cp "$TMP/mov/frame_0000.ply" "$TMP/many/frame_00012.ply"
expect 0 "render frame_10000" "$BIN" render "$TMP/many" --size 32x24
[ -s "$TMP/many/frame_10000.png" ] && ok || bad "render skipped frame_10000.ply"
has "$TMP/err" "rendered 2 frames" "render: frame_00012.ply is not a frame name"
