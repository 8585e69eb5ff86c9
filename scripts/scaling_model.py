#!/usr/bin/env python3
"""The model of docs/scaling.md: a distributed 3D run of 1e9 particles projected from the rows
that scripts/scaling.sh measured on this machine (bench/mpi_scaling's CSV).

  scripts/scaling_model.py out/scaling/scaling.csv [BYTES_PER_PARTICLE]

Inputs taken from the CSV (3D rows): the compute rate per core (1 rank, 1 thread, 1e6 particles);
the P2G seconds per particle-step (same row: ghosts cost one more P2G each); the ghost count of
the 2-rank split (one interface) at 1e6 particles, which fixes k in ghosts = k N^(2/3) for one
face; the bytes per ghost (bytes per step over ghosts per step). BYTES_PER_PARTICLE: the heap per
particle including the grid (`sandmpm bench --dim 3 --precision float`, default 162.6).

Assumptions (each is a line below): a node of 64 cores at this machine's per-core speed, one rank
per node; a rank's blocks form a cube-like region with 6 neighbours, each face receiving the same
layer as the 2-rank interface; full-duplex links, so a step's network time is the bytes received
over the bandwidth, plus 26 messages at 5 us each. The exchange overlaps with the binning and P2G
of the rank's inner blocks (dist/overlap.c: blocks whose blocks within two are all the rank's):
the work that can hide the network is the 1-rank row's sort + P2G seconds per particle-step times
the inner particles, (L - 2 d)^3 / L^3 of a cube of L cells on a side at 8 particles per cell, d
= 10 cells (the two blocks of the test and up to half a block more for the colour order); the
step takes compute + max(0, network - that). The columns without overlap are the step as before
(compute + network)."""
import csv
import sys

rows = list(csv.DictReader(open(sys.argv[1])))
bpp = float(sys.argv[2]) if len(sys.argv) > 2 else 162.6
r3 = [r for r in rows if r["dim"] == "3" and r["mode"] == "strong"]


def pick(ranks, threads, n):
    for r in r3:
        if int(r["ranks"]) == ranks and int(r["threads"]) == threads and abs(float(r["particles"]) / n - 1) < 0.05:
            return r
    sys.exit("scaling_model: no 3D strong row for %d ranks x %d threads, %g particles" % (ranks, threads, n))


one = pick(1, 1, 1e6)
two = pick(2, 1, 1e6)
rate_core = float(one["particle_steps_per_s"])
steps = float(one["steps"])
p2g_core = float(one["p2g_s"]) / (float(one["particles"]) * steps)  # s per particle-step, one core
n2 = float(two["particles"])
ghosts2 = float(two["ghosts_per_step"])  # both directions across the one interface
k = ghosts2 / 2 / n2 ** (2.0 / 3)  # one side's layer per face, over N^(2/3)
bytes_per_ghost = float(two["bytes_per_step"]) / (ghosts2 + float(two["migrating_per_step"]))

CORES = 64
N = 1e9
MSG_S = 5e-6
print("Inputs (measured): %.3g particle-steps/s per core; P2G %.3g ns per particle-step per core; "
      "one interface's layer k = %.3g x N^(2/3) (%.0f ghosts per step at %.3g particles on 2 ranks); "
      "%.0f bytes per ghost; %.1f bytes per particle with the grid.\n" %
      (rate_core, p2g_core * 1e9, k, ghosts2, n2, bytes_per_ghost, bpp))
sort_p2g_core = (float(one["sort_s"]) + float(one["p2g_s"])) / (float(one["particles"]) * steps)
DEPTH = 10  # cells at a face that are not inner (see the top)
print("| nodes | particles per node | ghosts per node per step | memory per node | halo per step | "
      "network time at 25 / 100 Gb/s | compute time | inner share, work hiding the network | "
      "particle-steps/s at 25 / 100 Gb/s, no overlap | with overlap | limited by (25 / 100 Gb/s) |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for nodes in (16, 64, 256):
    n = N / nodes
    g = 6 * k * n ** (2.0 / 3)
    mem = (n + g) * bpp
    halo = g * bytes_per_ghost
    t_comp = n / (rate_core * CORES) + g * p2g_core / CORES
    t_net = [halo / (gbps * 1e9 / 8) + 26 * MSG_S for gbps in (25, 100)]
    rate = [N / (t_comp + t) for t in t_net]
    side = (n / 8) ** (1.0 / 3)  # cells
    inner = max(0.0, (side - 2 * DEPTH) / side) ** 3
    t_hide = sort_p2g_core * n * inner / CORES
    over = [N / (t_comp + max(0.0, t - t_hide)) for t in t_net]
    # what takes longer per step with the overlap: the network time left exposed, or compute
    limit = " / ".join("network" if t - t_hide > t_comp else "compute" for t in t_net)
    print("| %d | %.3g | %.3g (%.0f%%) | %.1f GB | %.2f GB | %.3f / %.3f s | %.3f s | %.0f%%, %.3f s | %.3g / %.3g | "
          "%.3g / %.3g | %s |" %
          (nodes, n, g, 100 * g / n, mem / 1e9, halo / 1e9, t_net[0], t_net[1], t_comp, 100 * inner, t_hide,
           rate[0], rate[1], over[0], over[1], limit))
