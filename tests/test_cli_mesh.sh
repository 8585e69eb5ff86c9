#!/usr/bin/env bash
# Mesh shapes through the program (issue 15; run from CTest: test_cli_mesh.sh SANDMPM SOURCE_DIR):
# a mesh file that is missing, unreadable, empty of triangles or (for sand) open gives exit code 2
# with the scene's line and the file named; `info` reports the triangles, the field's size and its
# build time, then reads the field from the cache; a scene with a mesh collider and a mesh object
# runs a frame; a mesh emitter emits (an open one is refused); an animated mesh collider (frame
# files written here) is reported and runs, a missing frame or one of another topology is named.
set -u
BIN=$1
SRC=$2
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
export SANDMPM_MESH_CACHE="$TMP/cache"
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
    if grep -qF -- "$2" "$1"; then ok; else bad "$3: \"$2\" not in: $(head -c 600 "$1")"; fi
}

cp "$SRC/scenes/meshes/bowl.obj" "$SRC/scenes/meshes/plough.obj" "$TMP/"
scene() { # file collider-shape [object-shape]
    local obj=${3:-"{ type = 'box', center = {0.4, 0.3, 0.4}, size = {0.1, 0.06, 0.1} }"}
    cat >"$1" <<LUA
return {
  dx = 0.02, frames = 1,
  domain = { min = {0, 0, 0}, max = {0.8, 0.6, 0.8} },
  materials = { sand = { density = 1600, E = 1e5, nu = 0.3, friction_angle = 35 } },
  objects = { { shape = $obj } },
  colliders = {
    { mode = "slip", friction = 0.5,
      shape = $2 },
  },
}
LUA
}
BOWL="{ type = 'mesh', file = 'bowl.obj', axis_angle = {1, 0, 0, -90}, position = {0.4, 0.27, 0.4} }"

# missing file: the scene's line (8: the collider's shape), the key and the path
scene "$TMP/missing.lua" "{ type = 'mesh', file = 'nope.obj' }"
expect 2 "missing mesh file" "$BIN" info "$TMP/missing.lua"
has "$TMP/err" "missing.lua:8: colliders[1].shape.file:" "missing: located"
has "$TMP/err" "nope.obj" "missing: file named"
expect 2 "missing mesh file (run)" "$BIN" run "$TMP/missing.lua" --out "$TMP/run_missing"
[ ! -e "$TMP/run_missing" ] && ok || bad "missing mesh: the run left an output directory"

# a file assimp cannot read
printf 'this is not a mesh\n\x01\x02\x03' >"$TMP/garbage.stl"
scene "$TMP/garbage.lua" "{ type = 'mesh', file = 'garbage.stl' }"
expect 2 "unreadable mesh file" "$BIN" info "$TMP/garbage.lua"
has "$TMP/err" "garbage.lua:8: colliders[1].shape.file:" "unreadable: located"
has "$TMP/err" "garbage.stl" "unreadable: file named"

# a file without triangles (only points)
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\n' >"$TMP/points.obj"
scene "$TMP/points.lua" "{ type = 'mesh', file = 'points.obj' }"
expect 2 "mesh without triangles" "$BIN" info "$TMP/points.lua"
has "$TMP/err" "points.obj" "no triangles: file named"

# an open surface is a one-sided collider (a warning) but not a solid to fill with sand (an error)
printf 'v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 3 2\nf 2 3 4\n' >"$TMP/sheet.obj"
scene "$TMP/sheet_col.lua" "{ type = 'mesh', file = 'sheet.obj', scale = 0.7, position = {0.05, 0.1, 0.05} }"
expect 0 "open mesh collider" "$BIN" info "$TMP/sheet_col.lua"
has "$TMP/err" "one-sided" "open collider: warning"
has "$TMP/out" "one_sided" "open collider: sign auto -> one_sided"
scene "$TMP/sheet_obj.lua" "$BOWL" "{ type = 'mesh', file = 'sheet.obj', position = {0.1, 0.3, 0.1} }"
expect 2 "open mesh object" "$BIN" info "$TMP/sheet_obj.lua"
has "$TMP/err" "sheet_obj.lua:5: objects[1].shape.file:" "open object: located"
has "$TMP/err" "sheet.obj" "open object: file named"

# bad keys of a mesh shape
scene "$TMP/key.lua" "{ type = 'mesh', file = 'bowl.obj', scal = 2 }"
expect 2 "mesh key typo" "$BIN" info "$TMP/key.lua"
has "$TMP/err" "colliders[1].shape.scal: unknown key (did you mean \"scale\"?)" "key typo"
scene "$TMP/nofile.lua" "{ type = 'mesh' }"
expect 2 "mesh without file" "$BIN" info "$TMP/nofile.lua"
has "$TMP/err" "colliders[1].shape.file: required" "no file"

# info: triangles, field size and build time; then the cache
scene "$TMP/bowl.lua" "$BOWL" "{ type = 'mesh', file = 'plough.obj', scale = 0.4, position = {0.4, 0.4, 0.4} }"
expect 0 "info mesh scene" "$BIN" info "$TMP/bowl.lua"
has "$TMP/out" "mesh         colliders[1].shape: bowl.obj: 2496 triangles; field" "info: collider mesh"
has "$TMP/out" "mesh         objects[1].shape: plough.obj: 112 triangles; field" "info: object mesh"
has "$TMP/out" "built in" "info: build time"
grep -q "MB, spacing 0.02 m, band 0.12 m, winding" "$TMP/out" && ok || bad "info: field size: $(cat "$TMP/out")"
expect 0 "info mesh scene again" "$BIN" info "$TMP/bowl.lua"
has "$TMP/out" "read from the cache" "info: cache"
ls "$TMP/cache"/*.sdf >/dev/null 2>&1 && ok || bad "no cache file in $TMP/cache"
parts=$(sed -n 's/^particles *\([0-9]*\) .*/\1/p' "$TMP/out")
[ "${parts:-0}" -gt 0 ] && ok || bad "mesh object seeded no particles"
expect 0 "run mesh scene" "$BIN" run "$TMP/bowl.lua" --out "$TMP/run_bowl" --quality test --frames 1
ls "$TMP/run_bowl" >/dev/null 2>&1 && ok || bad "run mesh scene: no output"

# a mesh emitter: info names its field, a run emits into it; an open mesh cannot be an emitter
printf 'v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\nf 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n' >"$TMP/cube.obj"
cat >"$TMP/emit.lua" <<LUA
return {
  dx = 0.02, frames = 2,
  domain = { min = {0, 0, 0}, max = {0.8, 0.6, 0.8} },
  materials = { sand = { density = 1600, E = 1e5, nu = 0.3, friction_angle = 35 } },
  emitters = { { shape = { type = "mesh", file = "cube.obj", scale = 0.05, position = {0.4, 0.4, 0.4} },
                 rate = 5 } },
}
LUA
expect 0 "info mesh emitter" "$BIN" info "$TMP/emit.lua"
has "$TMP/out" "mesh         emitters[1].shape: cube.obj: 12 triangles; field" "info: emitter mesh"
expect 0 "run mesh emitter" "$BIN" run "$TMP/emit.lua" --out "$TMP/run_emit" --quality test
nv=$(sed -n 's/^element vertex \([0-9]*\).*/\1/p' "$(ls "$TMP"/run_emit/frame_*.ply | tail -1)" 2>/dev/null)
[ "${nv:-0}" -gt 0 ] && ok || bad "mesh emitter: no particles in the last frame"
sed -e "s/cube.obj\", scale = 0.05/sheet.obj\", scale = 0.5/" "$TMP/emit.lua" >"$TMP/emit_open.lua"
expect 2 "open mesh emitter" "$BIN" info "$TMP/emit_open.lua"
has "$TMP/err" "emit_open.lua:5: emitters[1].shape.file:" "open emitter: located"

# an animated mesh collider: a plate moved by its vertices over 13 frame files; a missing frame
# file and a frame of another topology name the frame; only a collider may be animated
for f in $(seq 0 12); do
    x=$(awk -v f="$f" 'BEGIN { printf "%.6f", f * 0.5 / 30 }')
    awk -v x="$x" 'BEGIN {
        for (i = 0; i < 8; i++) printf "v %.6f %.6f %.6f\n", (i % 2 ? 0.03 : -0.03) + x, (int(i / 2) % 2 ? 0.1 : -0.1), (i >= 4 ? 0.15 : -0.15)
        print "f 1 3 2\nf 2 3 4\nf 5 6 7\nf 6 8 7\nf 1 2 5\nf 2 6 5\nf 3 7 4\nf 4 7 8\nf 1 5 3\nf 3 5 7\nf 2 4 6\nf 4 8 6"
    }' >"$TMP/$(printf 'plate_%04d.obj' "$f")"
done
PLATE="{ type = 'mesh', file = 'plate_%04d.obj', frames = 13, fps = 30, position = {0.2, 0.3, 0.4} }"
scene "$TMP/anim.lua" "$PLATE"
expect 0 "info animated mesh" "$BIN" info "$TMP/anim.lua"
has "$TMP/out" "mesh         colliders[1].shape: plate_%04d.obj (13 frames at 30 fps): 12 triangles; field" "info: animated mesh"
expect 0 "run animated mesh" "$BIN" run "$TMP/anim.lua" --out "$TMP/run_anim" --quality test --frames 1
scene "$TMP/anim_missing.lua" "{ type = 'mesh', file = 'plate_%04d.obj', frames = 14, fps = 30 }"
expect 2 "animated mesh: missing frame" "$BIN" info "$TMP/anim_missing.lua"
has "$TMP/err" "anim_missing.lua:8: colliders[1].shape.file: frame 13:" "missing frame: located"
has "$TMP/err" "plate_0013.obj" "missing frame: file named"
cp "$TMP/plate_0000.obj" "$TMP/odd_0000.obj"
printf 'v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n' >"$TMP/odd_0001.obj"
scene "$TMP/anim_odd.lua" "{ type = 'mesh', file = 'odd_%04d.obj', frames = 2, fps = 30 }"
expect 2 "animated mesh: other topology" "$BIN" info "$TMP/anim_odd.lua"
has "$TMP/err" "frame 1 (" "other topology: frame named"
has "$TMP/err" "odd_0001.obj): not the first frame's topology" "other topology: file named"
scene "$TMP/anim_obj.lua" "$BOWL" "{ type = 'mesh', file = 'plate_%04d.obj', frames = 13, fps = 30 }"
expect 2 "animated mesh object" "$BIN" info "$TMP/anim_obj.lua"
has "$TMP/err" "only be a collider's shape" "animated object refused"
scene "$TMP/anim_pat.lua" "{ type = 'mesh', file = 'plate.obj', frames = 13, fps = 30 }"
expect 2 "animated mesh without a pattern" "$BIN" info "$TMP/anim_pat.lua"
has "$TMP/err" "frame number pattern" "no pattern"

# 2D: the z = 0 slice of the bowl turned out of the plane (a 3D rotation is allowed for a mesh)
cat >"$TMP/bowl2d.lua" <<LUA
return {
  dim = 2, dx = 0.01, frames = 1,
  domain = { min = {0, 0}, max = {0.6, 0.45} },
  materials = { sand = { density = 2200, E = 3.537e5, nu = 0.3, friction_angle = 30 } },
  objects = { { shape = { type = "box", center = {0.3, 0.16}, size = {0.06, 0.06} } } },
  colliders = { { shape = { type = "mesh", file = "bowl.obj", axis_angle = {1, 0, 0, -90}, position = {0.3, 0.25} },
                  mode = "slip" } },
}
LUA
expect 0 "info 2D mesh scene" "$BIN" info "$TMP/bowl2d.lua"
has "$TMP/out" "mesh         colliders[1].shape: bowl.obj: 147 segments; field" "info: 2D outline"

echo "test_cli_mesh: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
