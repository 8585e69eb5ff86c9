#!/usr/bin/env bash
# Implicit against explicit (issue 14): builds the Release double program (build-implicit) and runs
# the thesis's Young's modulus scene (2D, 761 particles, 2 s) at E = 1e5, 1e6, 1e7 and the castle
# (3D preview, 13,723 particles, 1 s) with both integrators, printing one Markdown table row per
# run: steps, wall time (diagnostics.csv's last row), Newton and GMRES iterations, the centre of
# mass of the last frame and, for implicit rows, the explicit run's wall time over this one's
# (above 1: implicit is faster) and how far its centre of mass lies from the explicit run's, in
# per cent of the explicit centre's height above the ground.
#   scripts/implicit-table.sh               all rows (a few minutes)
#   scripts/implicit-table.sh --threads 1   extra arguments go to every `sandmpm run`
# Timing noise on a shared machine is 5-20%: compare within one run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh >/dev/null
B=build-implicit
cmake -S . -B "$B" -DCMAKE_BUILD_TYPE=Release -DSM_DOUBLE=ON -DSM_SIBLING=OFF >/dev/null
cmake --build "$B" -j "$(nproc 2>/dev/null || echo 2)" --target sandmpm_cli -- --no-print-directory >/dev/null
EXTRA=("$@")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD 2>/dev/null || commit="$commit (with uncommitted changes)"
echo "# $(date -Iseconds), commit $commit, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1), $(nproc) cores"
echo
echo "| scene | integrator, max dt | steps | wall | Newton | GMRES | centre of mass (m) | explicit wall / this | centre of mass vs explicit |"
echo "|---|---|---|---|---|---|---|---|---|"

# run LABEL SCENE GROUND_Y ARGS...: one row; the explicit row of a group goes first (its wall and
# centre are the reference of the implicit rows after it).
ref_wall=0 ref_comy=0
run() {
    local label=$1 scene=$2 ground=$3
    shift 3
    rm -rf "$tmp/o"
    "$B/sandmpm" run "$scene" "$@" "${EXTRA[@]}" --checkpoint-every 0 -q --out "$tmp/o" >/dev/null
    awk -F, -v L="$label" -v rw="$ref_wall" -v ry="$ref_comy" -v g="$ground" -v s="$scene" '
        NR > 1 { n += $18; gm += $19; steps = $4; w = $22; x = $9; y = $10; z = $11 }
        END {
            com = (s ~ /castle/) ? sprintf("(%.4f, %.4f, %.4f)", x, y, z) : sprintf("(%.4f, %.4f)", x, y)
            if (L ~ /^explicit/) { ratio = "-"; off = "-"; n = "-"; gm = "-" }
            else { ratio = sprintf("%.2f", rw / w); off = sprintf("%+.1f%%", 100 * (y - ry) / (ry - g)) }
            name = (s ~ /castle/) ? "castle preview" : "youngs_modulus"
            printf "| %s | %s | %d | %.2f s | %s | %s | %s | %s | %s |\n", name, L, steps, w, n, gm, com, ratio, off
        }' "$tmp/o/diagnostics.csv" | tee "$tmp/row"
    if [[ $label == explicit* ]]; then
        ref_wall=$(awk -F, 'END { print $22 }' "$tmp/o/diagnostics.csv")
        ref_comy=$(awk -F, 'END { print $10 }' "$tmp/o/diagnostics.csv")
    fi
}

ym=scenes/youngs_modulus.lua
for E in 1e5 1e6 1e7; do
    run "explicit, E = $E" $ym 0.05 --set E=$E --set explicit=true
    run "implicit, E = $E, 7.5e-4" $ym 0.05 --set E=$E
    run "implicit, E = $E, 1/24" $ym 0.05 --set E=$E --set max_dt=0.041666667
done
run "explicit, 1e-3" scenes/castle.lua 0.05 --set explicit=true
run "implicit, 1e-3" scenes/castle.lua 0.05
run "implicit, 4e-3" scenes/castle.lua 0.05 --set max_dt=4e-3
