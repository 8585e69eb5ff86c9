#!/usr/bin/env bash
# Distributed scaling on this machine (issue 19, docs/scaling.md): strong scaling (a fixed 3D
# block on 1 and 2 ranks, 4 oversubscribed: functional only), weak scaling (a fixed block per
# rank), the implicit integrator's strong scaling (a 125k-particle block, 3 steps of 1 ms), the
# halo traffic per step and the time per stage, from bench/mpi_scaling; then the model
# for 1e9 particles (scripts/scaling_model.py) from those rows.
#   scripts/scaling.sh [BUILD]     (default build-rel: a Release build with SM_MPI)
# Writes out/scaling/scaling.csv and out/scaling/model.md.
set -euo pipefail
cd "$(dirname "$0")/.."
B=${1:-build-rel}
[ -x "$B/bench/mpi_scaling" ] || cmake --build "$B" --target mpi_scaling >/dev/null
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mkdir -p out/scaling
csv=out/scaling/scaling.csv
{
    printf 'dim,mode,ranks,threads,particles,steps,seconds,particle_steps_per_s,ghosts_per_step,migrating_per_step,bytes_per_step,messages_per_step,imbalance,recuts'
    "$B/bench/mpi_scaling" --stage-names 2>/dev/null || true
    echo ',exchange_wait_s,overlap,early_per_step' # the slowest rank's time blocked on the exchange's messages; the overlap setting, the particles scattered while the messages travelled
} > "$csv"
run() { # ranks threads args... (OV=0: the exchange not overlapped with the inner blocks' P2G)
    local np=$1 th=$2; shift 2
    mpirun -np "$np" --oversubscribe --bind-to none -x OMP_NUM_THREADS="$th" "$B/bench/mpi_scaling" "$@" "$th" ${OV:+"$OV"} |
        tee -a "$csv"
}
for n in 200000 1000000; do
    run 1 1 3 strong $n 30
    run 1 2 3 strong $n 30
    run 2 1 3 strong $n 30
    OV=0 run 2 1 3 strong $n 30 # the same without the overlap
    run 4 1 3 strong $n 10 # oversubscribed: functional only
done
run 1 1 3 weak 500000 30
run 2 1 3 weak 500000 30
run 1 1 2 strong 1000000 30
run 2 1 2 strong 1000000 30
OV=0 run 2 1 2 strong 1000000 30
for np_th in "1 1" "1 2" "2 1" "4 1"; do # the implicit integrator (4 ranks oversubscribed: functional only)
    run $np_th 3 implicit 125000 3
done
/usr/bin/python3 scripts/scaling_model.py "$csv" | tee out/scaling/model.md
