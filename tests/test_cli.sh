#!/usr/bin/env bash
# The sandmpm program end to end (run from CTest: test_cli.sh SANDMPM SOURCE_DIR):
# every shipped scene loads (`info`) and runs a frame at test quality, writing PLY, VTK, PVD, CSV
# and the render manifest; `info` reports the particles the run actually has; --set reaches the
# scene; bad input gives exit code 2 with the cause named and leaves no output directory; a
# missing run directory gives exit code 4; `render` turns a run into PNG files.
set -u
BIN=$1
SRC=$2
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
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
printf 'os.execute("true")\nreturn { dx = 0.02, frames = 1 }\n' > "$TMP/os.lua"
expect 2 "os.execute" "$BIN" info "$TMP/os.lua"
printf 'require("x")\nreturn { dx = 0.02, frames = 1 }\n' > "$TMP/req.lua"
expect 2 "require" "$BIN" info "$TMP/req.lua"
printf 'while true do end\n' > "$TMP/loop.lua"
expect 2 "runaway loop" "$BIN" info "$TMP/loop.lua"
has "$TMP/err" 'instruction limit' "instruction limit message"
printf 'return { dim = 3, dx = 0.001, frames = 1, domain = { min = {0,0,0}, max = {20,20,20} } }\n' > "$TMP/huge.lua"
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

# render: a run directory to PNG; a missing directory is an I/O error (4); a corrupt frame is 2.
expect 0 "render" "$BIN" render "$TMP/run_castle" --size 160x90
[ -s "$TMP/run_castle/frame_0001.png" ] && ok || bad "render wrote no PNG"
expect 4 "render missing dir" "$BIN" render "$TMP/no_such_run"
mkdir -p "$TMP/corrupt" && printf 'ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\nend_header\n' > "$TMP/corrupt/frame_0000.ply"
expect 2 "render corrupt frame" "$BIN" render "$TMP/corrupt"

echo "test_cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
