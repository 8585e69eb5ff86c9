#!/usr/bin/env bash
# The sandmpm program end to end (run from CTest: test_cli.sh SANDMPM SOURCE_DIR [PART]).
# PART basic (CTest test_cli): every shipped scene loads (`info`) and runs a frame at test quality,
# writing PLY, VTK, PVD, CSV and the render manifest; `info` reports the particles the run actually
# has; --set reaches the scene; bad input gives exit code 2 with the cause named and leaves no
# output directory; a missing run directory gives exit code 4; `render` turns a run into PNG
# files; `bench`.
# PART faults (CTest test_cli_faults): hostile and careless input and disk trouble, see
# tests/test_cli_faults.sh. PART info (CTest test_cli_info): `info`'s estimates against a run, see
# tests/test_cli_info.sh. Without PART: basic and faults.
set -u
BIN=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") # absolute: some tests run in other folders
SRC=$2
PART=${3:-all}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
export SANDMPM_MESH_CACHE="$TMP/mesh-cache" # the mesh scenes' fields, not into the source tree
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*" >&2; }
expect() { # expected-code description command...
    local want=$1 what=$2; shift 2
    "$@" >"$TMP/out" 2>"$TMP/err"
    local got=$?
    if [ "$got" -eq "$want" ]; then ok; else bad "$what: exit $got, expected $want; stderr: $(cat "$TMP/err")"; fi
}
has() { # file text description
    if grep -qF -- "$2" "$1"; then ok; else bad "$3: \"$2\" not in: $(head -c 400 "$1")"; fi
}

if [ "$PART" = info ]; then
    . "$SRC/tests/test_cli_info.sh"
    echo "test_cli (info): $pass passed, $fail failed"
    [ "$fail" -eq 0 ]
    exit
fi
if [ "$PART" = faults ]; then
    . "$SRC/tests/test_cli_faults.sh"
    echo "test_cli (faults): $pass passed, $fail failed"
    [ "$fail" -eq 0 ]
    exit
fi

for scene in "$SRC"/scenes/*.lua; do
    name=$(basename "$scene" .lua)
    expect 0 "info $name" "$BIN" info "$scene" --quality test
    want=$(sed -n 's/^particles *\([0-9]*\) .*/\1/p' "$TMP/out")
    expect 0 "run $name" "$BIN" run "$scene" --quality test --frames 1 --out "$TMP/run_$name"
    for f in frame_0000.ply frame_0001.ply frame_0001.vtp frames.pvd diagnostics.csv render.txt; do
        [ -s "$TMP/run_$name/$f" ] && ok || bad "$name: $f missing"
    done
    got=$(sed -n 's/^element vertex //p' "$TMP/run_$name/frame_0000.ply" | head -1 | tr -d '\r')
    [ -n "$want" ] && [ "$got" = "$want" ] && ok || bad "$name: info says $want particles, frame 0 has $got"
    [ "$(wc -l < "$TMP/run_$name/diagnostics.csv")" -eq 3 ] && ok || bad "$name: diagnostics.csv should have 3 lines"
done

# --set reaches the scene: friction_angle's angle is written into every particle's friction angle.
expect 0 "--set angle" "$BIN" info "$SRC/scenes/friction_angle.lua" --quality test --set angle=20
expect 2 "--set unknown key" "$BIN" info "$SRC/scenes/friction_angle.lua" --quality test --set anglee=20
has "$TMP/err" 'anglee' "unknown --set key named"
expect 0 "default dx override" "$BIN" info --set dx=0.03 --quality test
has "$TMP/out" "dx           0.03 m" "--set dx reaches the default scene"

# Bad input: exit 2, message, no output directory.
printf 'return { dim = 3, dx = 0.02, frames = 1,\n  colliders = { { shape = { type = "halfspace", point = {0,0.1,0}, normal = {0,1,0} }, mode = "slipp" } } }\n' > "$TMP/bad_mode.lua"
expect 2 "bad mode" "$BIN" run "$TMP/bad_mode.lua" --out "$TMP/never"
has "$TMP/err" 'colliders[1].mode: expected "sticky", "slip" or "separate", got "slipp"' "enum message"
[ ! -e "$TMP/never" ] && ok || bad "output directory created for a bad scene"
printf 'return { dim = 3, dx = 0.02, frames = 1,\n  materials = { sand = { E = -5 } } }\n' > "$TMP/bad_e.lua"
expect 2 "negative E" "$BIN" run "$TMP/bad_e.lua" --out "$TMP/never"
has "$TMP/err" 'materials.sand.E: must be > 0, got -5' "range message"
printf 'return { dim = 3, dx = 0.02, frames = 1\n  colliders = {} }\n' > "$TMP/syntax.lua"
expect 2 "syntax error" "$BIN" run "$TMP/syntax.lua" --out "$TMP/never"
has "$TMP/err" 'syntax.lua:2:' "syntax error line"
printf 'local f = io.open("/etc/passwd")\nreturn { dx = 0.02, frames = 1 }\n' > "$TMP/io.lua"
expect 2 "io.open" "$BIN" info "$TMP/io.lua"
# Started by mpirun as several ranks, a command other than run (or a build without MPI): a clear
# refusal (tests/test_cli_mpi.sh runs `run` across ranks).
expect 2 "info as several MPI ranks" env OMPI_COMM_WORLD_SIZE=2 "$BIN" info
has "$TMP/err" "MPI ranks" "info as several MPI ranks: the message"
printf 'os.execute("true")\nreturn { dx = 0.02, frames = 1 }\n' > "$TMP/os.lua"
expect 2 "os.execute" "$BIN" info "$TMP/os.lua"
printf 'require("x")\nreturn { dx = 0.02, frames = 1 }\n' > "$TMP/req.lua"
expect 2 "require" "$BIN" info "$TMP/req.lua"
printf 'while true do end\n' > "$TMP/loop.lua"
expect 2 "runaway loop" "$BIN" info "$TMP/loop.lua"
has "$TMP/err" 'instruction limit' "instruction limit message"
printf 'return { dim = 3, dx = 0.001, frames = 1, domain = { min = {0,0,0}, max = {20,20,20} },\n  materials = { sand = { friction_angle = 30 } },\n  objects = { { material = "sand", shape = { type = "box", center = {10,10,10}, half_extent = {9,9,9} } } } }\n' > "$TMP/huge.lua"
expect 2 "too large for memory" "$BIN" info "$TMP/huge.lua"
has "$TMP/err" 'GB' "memory estimate in the message"
expect 2 "missing scene" "$BIN" run "$TMP/nope.lua" --out "$TMP/never"
expect 2 "bad option" "$BIN" run --frames zero
expect 2 "bad quality" "$BIN" run --quality ultra
expect 2 "unknown command" "$BIN" frobnicate
expect 0 "help" "$BIN" --help
expect 0 "run help" "$BIN" run --help
expect 0 "version" "$BIN" --version
has "$TMP/out" "sandmpm" "version text"
expect 0 "-V" "$BIN" -V
has "$TMP/out" "precision)" "-V: the version text"
expect 0 "help run" "$BIN" help run
has "$TMP/out" "usage: sandmpm run" "help run: the run command's help"
expect 0 "help render" "$BIN" help render
has "$TMP/out" "usage: sandmpm render" "help render: the render command's help"
expect 2 "help of an unknown command" "$BIN" help rnu
has "$TMP/err" 'did you mean "run"' "help rnu: a suggestion"
expect 2 "mistyped command" "$BIN" rendr
has "$TMP/err" 'did you mean "render"' "rendr: a suggestion"
expect 2 "far from every command" "$BIN" frobnicate
expect 2 "--set unknown key on the built-in scene" "$BIN" info --quality test --set foo=1
has "$TMP/err" "(built in) scenes/default.lua" "the built-in scene's name in the message"
# Warnings for what looks like a mistake: an angle in radians, sand seeded inside a collider (a
# quarter of this box lies below the sticky ground at y = 0.25); the shipped scenes give none.
cat > "$TMP/warn.lua" <<'EOF2'
return {
  dim = 2, dx = 0.05, ppc = 4, frames = 1,
  domain = { min = {0, 0}, max = {1, 1} },
  materials = { sand = { model = "sand", friction_angle = params.fa or 0.52 } },
  objects = { { shape = { type = "box", center = {0.5, params.y or 0.3}, half_extent = {0.1, 0.1} }, material = "sand" } },
  colliders = { { shape = { type = "halfspace", point = {0, 0.25}, normal = {0, 1} }, mode = "sticky" } },
}
EOF2
expect 0 "warnings: info" "$BIN" info "$TMP/warn.lua"
has "$TMP/err" "warn.lua:4: materials.sand.friction_angle: 0.52 looks like radians (0.52 rad = 29.8 degrees)" "radians warning"
has "$TMP/err" "warn.lua:5: objects[1]: 16 of its 64 particles are seeded inside colliders[1]" "inside-collider warning"
expect 0 "no warnings" "$BIN" info "$TMP/warn.lua" --set fa=30 --set y=0.5
grep -q "warning" "$TMP/err" && bad "warnings for a sound scene: $(cat "$TMP/err")" || ok
for f in "$SRC"/scenes/*.lua; do
    "$BIN" info "$f" --quality test >/dev/null 2>"$TMP/err"
    grep -q "warning" "$TMP/err" && bad "$f warns: $(cat "$TMP/err")" || ok
done
cores=$(getconf _NPROCESSORS_ONLN)
expect 0 "--threads above the cores" "$BIN" info --quality test --threads $((cores + 1))
has "$TMP/err" "more threads than cores" "--threads $((cores + 1)) on $cores cores: the warning"
expect 0 "--threads within the cores" "$BIN" info --quality test --threads 1
grep -q "more threads than cores" "$TMP/err" && bad "--threads 1: a warning" || ok
grep -q "did you mean" "$TMP/err" && bad "frobnicate: a suggestion" || ok

# render: a run directory to PNG; a missing directory is an I/O error (4); a corrupt frame is 2.
expect 0 "render" "$BIN" render "$TMP/run_castle" --size 160x90
[ -s "$TMP/run_castle/frame_0001.png" ] && ok || bad "render wrote no PNG"
expect 4 "render missing dir" "$BIN" render "$TMP/no_such_run"
mkdir -p "$TMP/corrupt" && printf 'ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\nend_header\n' > "$TMP/corrupt/frame_0000.ply"
expect 2 "render corrupt frame" "$BIN" render "$TMP/corrupt"

# outputs.up = "z": the frames say so and hold (x, -z, y); `render` turns them back, so the images
# are those of the y-up run, byte for byte; a bad value is refused with the choices.
for up in y z; do
    printf 'return {\n  dim = 3, dx = 0.04, ppc = 2, frames = 1,\n  domain = { min = {0, 0, 0}, max = {1, 0.6, 0.8} },\n  materials = { sand = { model = "sand", friction_angle = 30 } },\n  objects = { { shape = { type = "box", center = {0.5, 0.3, 0.4}, size = {0.3, 0.2, 0.2} }, material = "sand", velocity = {0.5, 0, 0.3} } },\n  outputs = { up = "%s" },\n}\n' "$up" > "$TMP/up_$up.lua"
    expect 0 "run with outputs.up = $up" "$BIN" run "$TMP/up_$up.lua" --out "$TMP/up_$up"
    has "$TMP/up_$up/frame_0001.ply" "comment up $up" "outputs.up = $up: the PLY header says it"
    expect 0 "render the run with outputs.up = $up" "$BIN" render "$TMP/up_$up" --size 160x90
done
cmp -s "$TMP/up_y/frame_0001.ply" "$TMP/up_z/frame_0001.ply" && bad "outputs.up: the z-up frame is the y-up one" || ok
cmp -s "$TMP/up_y/frame_0001.png" "$TMP/up_z/frame_0001.png" && ok || bad "render of a z-up run's frames differs from the y-up run's"
sed 's/up = "z"/up = "x"/' "$TMP/up_z.lua" > "$TMP/up_x.lua"
expect 2 "outputs.up = x" "$BIN" info "$TMP/up_x.lua"
has "$TMP/err" '"y"' "outputs.up = x: the choices named"

# Output folders cannot mix runs (docs/outputs.md): run_manifest.txt names the scene, its hash and
# the frames written; a re-run of the same scene replaces its files; another run (here the same
# file with another --set value) is refused (exit 2, the folder untouched) unless --overwrite,
# which removes the listed files and only those; `render` renders the listed frames only; a folder
# without a manifest is refused by `run` and rendered whole by `render`, with a note.
cat > "$TMP/drop.lua" <<'EOF2'
return {
  dim = 2, dx = 0.05, ppc = 4, frames = 2,
  domain = { min = {0, 0}, max = {1, 1} },
  materials = { sand = { model = "sand", friction_angle = 30 } },
  objects = { { shape = { type = "box", center = {0.5, params.y or 0.5}, half_extent = {0.1, 0.1} }, material = "sand" } },
}
EOF2
m=$TMP/mix
drop=$TMP/drop.lua
expect 0 "mix: first run" "$BIN" run "$drop" --out "$m"
has "$m/run_manifest.txt" "scene $drop" "manifest: the scene"
has "$m/run_manifest.txt" "frame_files ply 0 2" "manifest: the PLY frames"
has "$m/run_manifest.txt" "frame_files vtp 0 2" "manifest: the VTK frames"
has "$m/run_manifest.txt" "state complete" "manifest: the state"
grep -qE '^scene_hash [0-9a-f]{16}$' "$m/run_manifest.txt" && ok || bad "manifest: no scene_hash: $(cat "$m/run_manifest.txt")"
# diagnostics.csv (docs/outputs.md): units in the header; frame 0 without steps (dt empty); per-frame
# steps add up to the running total; the mass is constant and positive; the centre of mass of the
# box falls (y decreases); the implicit castle reports its Newton and GMRES iterations per frame, an
# explicit run none.
hdr="frame,time_s,steps_frame,steps_total,dt_min_s,dt_max_s,particles,total_mass_kg,com_x_m,com_y_m,com_z_m,kinetic_energy_J,elastic_energy_J,momentum_x_kg_m_s,momentum_y_kg_m_s,momentum_z_kg_m_s,max_speed_m_s,newton_iterations_frame,gmres_iterations_frame,newton_unconverged_total,wall_s_frame,wall_s_total"
diag_check() { # csv implicit(0|1) what
    [ "$(head -1 "$1")" = "$hdr" ] && ok || bad "$3: diagnostics.csv header: $(head -1 "$1")"
    awk -F, -v imp="$2" 'NR == 1 { next }
        NF != 22 { print "fields: " NF; b = 1 }
        NR == 2 && ($1 != 0 || $3 != 0 || $5 != "" || $6 != "" || $18 != 0) { print "frame 0: " $0; b = 1 }
        NR > 2 && ($3 <= 0 || $5 <= 0 || $6 < $5) { print "frame " $1 " steps/dt: " $0; b = 1 }
        { sum += $3; if ($4 != sum) { print "steps_total " $4 " != sum " sum; b = 1 } }
        NR == 2 { m = $8; y0 = $10 } !($8 > 0) || ($8 - m) * ($8 - m) > 1e-12 * m * m { print "mass " $8 " vs " m; b = 1 }
        NR > 2 { y = $10; if (imp == 1 && !($18 > 0 && $19 >= $18)) { print "implicit: newton " $18 " gmres " $19; b = 1 }
                 if (imp == 0 && ($18 != 0 || $19 != 0)) { print "explicit: newton " $18; b = 1 } }
        END { if (!(y < y0)) { print "centre of mass y " y0 " -> " y; b = 1 } exit b }' "$1" > "$TMP/diag_bad" && ok ||
        bad "$3: diagnostics.csv: $(head -3 "$TMP/diag_bad")"
}
diag_check "$m/diagnostics.csv" 0 "falling box (explicit)"
diag_check "$TMP/run_castle/diagnostics.csv" 1 "castle (implicit)"
expect 0 "mix: the same scene, shorter" "$BIN" run "$drop" --frames 1 --out "$m"
has "$TMP/err" "replacing the earlier run of the same scene" "same scene: said so"
[ ! -e "$m/frame_0002.ply" ] && [ ! -e "$m/frame_0002.vtp" ] && ok || bad "same scene, shorter: the old frame 2 is left"
has "$m/run_manifest.txt" "frame_files ply 0 1" "same scene, shorter: manifest"
rm -rf "$TMP/mix_before" && cp -a "$m" "$TMP/mix_before"
expect 2 "mix: another run" "$BIN" run "$drop" --set y=0.6 --frames 1 --out "$m"
has "$TMP/err" "holds frames 0..1 of another run ($drop" "another run: the other run named"
has "$TMP/err" "--overwrite" "another run: the way out named"
diff -r "$m" "$TMP/mix_before" >/dev/null && ok || bad "a refused run changed the folder: $(diff -r "$m" "$TMP/mix_before" | head -3)"
expect 2 "--resume with --overwrite" "$BIN" run "$drop" --out "$m" --resume --overwrite
echo "mine" > "$m/notes.txt"
cp "$m/frame_0001.ply" "$m/frame_0007.ply" # not the listed run's: --overwrite keeps it
expect 0 "mix: --overwrite" "$BIN" run "$drop" --set y=0.6 --frames 1 --out "$m" --overwrite
has "$TMP/err" "removed 9 files" "--overwrite: the old run's 9 files (2 PLY, 2 VTK, pvd, csv, render.txt, poses.csv, manifest)"
[ -f "$m/notes.txt" ] && [ -f "$m/frame_0007.ply" ] && ok || bad "--overwrite removed files the old run did not list"
old_hash=$(sed -n 's/^scene_hash //p' "$TMP/mix_before/run_manifest.txt")
new_hash=$(sed -n 's/^scene_hash //p' "$m/run_manifest.txt")
[ -n "$new_hash" ] && [ "$new_hash" != "$old_hash" ] && ok || bad "--overwrite: the manifest's hash $new_hash (was $old_hash)"
expect 0 "render: the listed frames" "$BIN" render "$m" --size 32x24
[ -f "$m/frame_0001.png" ] && [ ! -e "$m/frame_0007.png" ] && ok || bad "render: rendered an unlisted frame (or not a listed one)"
has "$m/run_manifest.txt" "frame_files png 0 1" "render: the PNG files listed"
# render --frames: a range of the listed frames only
rm -f "$m"/frame_*.png
expect 0 "render --frames 1" "$BIN" render "$m" --size 32x24 --frames 1
[ -f "$m/frame_0001.png" ] && [ ! -e "$m/frame_0000.png" ] && ok || bad "render --frames 1: $(ls "$m")"
expect 0 "render --frames ..0" "$BIN" render "$m" --size 32x24 --frames ..0
[ -f "$m/frame_0000.png" ] && ok || bad "render --frames ..0: no frame 0"
expect 2 "render --frames 3..9 (none listed)" "$BIN" render "$m" --size 32x24 --frames 3..9
has "$TMP/err" "has frames 0..1, none of them asked for" "render --frames outside the run: said so"
expect 2 "render --frames 2..1" "$BIN" render "$m" --frames 2..1
rm "$m/run_manifest.txt"
expect 2 "run into frames without a manifest" "$BIN" run "$drop" --frames 1 --out "$m"
has "$TMP/err" "but no run_manifest.txt" "no manifest: said so"
expect 0 "render without a manifest" "$BIN" render "$m" --size 32x24
has "$TMP/err" "note:" "render without a manifest: a note"
[ -f "$m/frame_0007.png" ] && ok || bad "render without a manifest: not every frame rendered"

# What the run says (stderr is not a terminal here: a line per frame): frame 0's line has no rate
# or ETA yet (none is known), the end a summary line; -q says nothing on a sound run, -v a line per
# frame with its steps and dt range; --end that is not a whole number of frames is warned about
# (a whole one is not); --video without --render says that it renders.
d=$TMP/talk
expect 0 "talk: a run" "$BIN" run "$drop" --out "$d"
grep '^frame 0/2' "$TMP/err" | grep -q 'particle-steps/s\|ETA' && bad "frame 0's line has a rate or ETA: $(grep '^frame 0/' "$TMP/err")" || ok
has "$TMP/err" "computing frame 1" "frame 0's line says what is going on"
grep '^frame 2/2' "$TMP/err" | grep -q 'particle-steps/s' && ok || bad "frame 2's line has no rate: $(cat "$TMP/err")"
steps=$(tail -1 "$d/diagnostics.csv" | cut -d, -f4)
has "$TMP/err" "sandmpm: done: 3 frames (0..2), $steps steps" "the summary: frames and steps"
has "$TMP/err" "files in $d/ (listed in run_manifest.txt)" "the summary: where the files are"
expect 0 "talk: -q" "$BIN" run "$drop" --out "$d" -q
[ ! -s "$TMP/err" ] || [ "$(grep -vc 'replacing the earlier run' "$TMP/err")" -eq 0 ] && ok || bad "-q: $(cat "$TMP/err")"
expect 0 "talk: --verbose" "$BIN" run "$drop" --out "$d" --verbose
[ "$(grep -c '^frame [12]/2 .* steps (dt [0-9.e-]*\.\.[0-9.e-]* s)' "$TMP/err")" -eq 2 ] && ok || bad "-v: no detailed frame lines: $(cat "$TMP/err")"
expect 2 "talk: -q -v" "$BIN" run "$drop" --out "$d" -q -v
expect 0 "talk: --end not a whole number of frames" "$BIN" run "$drop" --out "$d" --end 0.05
has "$TMP/err" "warning: --end 0.05 s is not a whole number of frames at 24 fps (1.2 frames); running 2 frames, to t = 0.0833333 s" "--end 0.05 warned"
expect 0 "talk: --end a whole number of frames" "$BIN" run "$drop" --out "$d" --end 0.125
grep -q "not a whole number" "$TMP/err" && bad "--end 0.125 (3 frames) warned: $(cat "$TMP/err")" || ok
"$BIN" run "$drop" --out "$d" --frames 1 --video >/dev/null 2>"$TMP/err"
has "$TMP/err" "note: --video needs the frames as pictures, so it renders them too" "--video without --render explained"
[ -s "$d/frame_0001.png" ] && ok || bad "--video without --render: no PNG frames"

# bench: `sandmpm bench --csv` in this build's precision and, if the program of the other
# precision (sandmpm-float / sandmpm-double, CMake SM_SIBLING) is next to this one, in that one
# too: the exact header, one row per dimension and thread count, sane fields. No timing checks.
# A copy of the program alone in a directory has no sibling: a note and exit 0 by default, exit 2
# when the missing precision is asked for.
own=$("$BIN" --version | sed -n 's/.*(\(float\|double\) precision).*/\1/p')
if [ "$own" = double ]; then other=float; else other=double; fi
[ -n "$own" ] && ok || bad "bench: no precision in --version"
bench_csv() { # precision
    expect 0 "bench --csv $1" "$BIN" bench --csv --particles 2000 --steps 2 --warmup 1 --dim 2,3 --threads 1,2 --precision "$1"
    [ "$(head -1 "$TMP/out")" = "dim,precision,threads,particles,particle_steps_per_s,bytes_per_particle" ] && ok ||
        bad "bench $1: header is \"$(head -1 "$TMP/out")\""
    tail -n +2 "$TMP/out" > "$TMP/rows"
    [ "$(wc -l < "$TMP/rows")" -eq 4 ] && ok || bad "bench $1: expected 4 rows, got: $(cat "$TMP/out")"
    [ "$(cut -d, -f1,3 "$TMP/rows" | sort -u | wc -l)" -eq 4 ] && ok || bad "bench $1: dim/threads cases repeat: $(cat "$TMP/rows")"
    awk -F, -v p="$1" 'NF != 6 || $1 !~ /^[23]$/ || $2 != p || $3 !~ /^[12]$/ || $4 !~ /^[0-9]+$/ || !($4 > 0) ||
                       $5 !~ /^[0-9.e+]+$/ || !($5 > 0) || $6 !~ /^[0-9.e+]+$/ || !($6 > 0) { print "bad row: " $0; b = 1 }
                       END { exit b }' "$TMP/rows" > "$TMP/bad_rows" && ok || bad "bench $1: $(cat "$TMP/bad_rows")"
}
bench_csv "$own"
if [ -x "$(dirname "$BIN")/sandmpm-$other" ]; then bench_csv "$other"; else echo "test_cli: no sandmpm-$other, bench $other not tested"; fi
expect 0 "bench table" "$BIN" bench --particles 500 --steps 1 --warmup 0 --dim 2 --threads 1 --precision "$own"
has "$TMP/out" "p2g" "bench table has the stages"
has "$TMP/out" "bytes/particle" "bench table has bytes per particle"
expect 2 "bench unknown option" "$BIN" bench --frobnicate
has "$TMP/err" '--frobnicate' "bench names the unknown option"
expect 2 "bench threads 0" "$BIN" bench --threads 0
expect 2 "bench dim 4" "$BIN" bench --dim 4
expect 2 "bench precision half" "$BIN" bench --precision half
expect 2 "bench steps 0" "$BIN" bench --steps 0
mkdir -p "$TMP/solo" && cp "$BIN" "$TMP/solo/sandmpm"
expect 0 "bench without sibling" "$TMP/solo/sandmpm" bench --csv --particles 500 --steps 1 --warmup 0 --dim 2 --threads 1
has "$TMP/err" "note:" "bench notes the missing sibling"
[ "$(tail -n +2 "$TMP/out" | cut -d, -f2 | sort -u)" = "$own" ] && ok || bad "bench without sibling: rows $(cat "$TMP/out")"
expect 2 "bench without sibling, --precision $other" "$TMP/solo/sandmpm" bench --csv --particles 500 --steps 1 --precision "$other"
has "$TMP/err" "$other" "bench names the missing precision"

[ "$PART" = all ] && . "$SRC/tests/test_cli_faults.sh"
echo "test_cli ($PART): $pass passed, $fail failed"
[ "$fail" -eq 0 ]
