"""Overhead of a Python World.step() loop against the same loop in C (bench/step_loop.c).

    PYTHONPATH=build/python /usr/bin/python3 python/bench/step_overhead.py build [--rounds 5] [--steps 30]

Runs both loops on the same 3D scene of about 100k particles (step_loop.c's "block"), alternating
C and Python, ROUNDS times each, and prints the per-step wall times (minimum and median) and the
Python loop's extra cost. On a shared machine two loops of the same simulation differ by more than
the binding costs, so it also measures that cost directly: the same loops on the world without
particles ("empty"), where a step costs almost nothing but the call itself. Both loops must end
with the same state hash (they simulate the same thing). Not a test: a benchmark (docs/python.md).
"""
import argparse
import os
import statistics
import subprocess
import sys
import time

import sandmpm as sm


def build(with_particles, threads):
    """The scene of step_loop.c's build()."""
    w = sm.World(dx=0.02, threads=threads)
    sand = sm.Material.sand()
    w.add_material(sand)
    w.add_collider(sm.Collider(sm.Shape.halfspace((0, 0.1, 0), (0, 1, 0))))
    if with_particles:
        w.seed(sm.Shape.box((0.5, 0.3, 0.5), (0.25, 0.2, 0.25)), sand, ppc=8)
    return w


def python_loop(scene, steps, warmup, threads):
    with build(scene == "block", threads) as w:
        for _ in range(warmup):
            w.step()
        t0 = time.perf_counter()
        for _ in range(steps):
            w.step()
        t1 = time.perf_counter()
        return {"particles": len(w), "seconds_per_step": (t1 - t0) / steps, "hash": "%016x" % w.state_hash()}


def advance_loop(scene, steps, warmup, threads):
    """The C loop inside this process: sm_world_advance (next_dt + step in C) over the simulated
    time that `steps` Python steps cover; per step = wall time / the steps advance took."""
    with build(scene == "block", threads) as w:
        for _ in range(warmup):
            w.step()
        probe_t0 = w.time
        with build(scene == "block", threads) as probe:  # how far `steps` adaptive steps go
            for _ in range(warmup + steps):
                probe.step()
            t_end = probe.time if probe.time > probe_t0 else probe_t0 + steps * 1e-3
        s0 = w.diagnostics()["steps"]
        t0 = time.perf_counter()
        sm.lib.sm_world_advance(w._w, t_end)
        t1 = time.perf_counter()
        return (t1 - t0) / max(1, w.diagnostics()["steps"] - s0)


def c_loop(exe, scene, steps, warmup, threads):
    out = subprocess.run([exe, scene, str(steps), str(warmup), str(threads)], check=True, capture_output=True,
                         text=True).stdout
    r = dict(line.split() for line in out.splitlines())
    return {"particles": int(r["particles"]), "seconds_per_step": float(r["seconds_per_step"]), "hash": r["hash"]}


def compare(exe, scene, rounds, steps, warmup, threads):
    c, py, adv = [], [], []
    for _ in range(rounds):
        rc = c_loop(exe, scene, steps, warmup, threads)
        rp = python_loop(scene, steps, warmup, threads)
        if rc["hash"] != rp["hash"] or rc["particles"] != rp["particles"]:
            sys.exit("step_overhead: the C and Python loops did not simulate the same thing (%s vs %s)" % (rc, rp))
        c.append(rc["seconds_per_step"])
        py.append(rp["seconds_per_step"])
        if scene == "block":
            adv.append(advance_loop(scene, steps, warmup, threads))
    return rc["particles"], c, py, adv


def report(scene, n, c, py, unit, scale):
    cm, pm = min(c), min(py)
    cmed, pmed = statistics.median(c), statistics.median(py)
    print("%s\n  %7d particles  C: min %9.3f med %9.3f %s/step   Python: min %9.3f med %9.3f %s/step   "
          "Python - C: min %+8.3f (%+.2f%%), median %+8.3f (%+.2f%%)"
          % (scene, n, cm * scale, cmed * scale, unit, pm * scale, pmed * scale, unit,
             (pm - cm) * scale, 100 * (pm - cm) / cm, (pmed - cmed) * scale, 100 * (pmed - cmed) / cmed))
    return pm - cm, cm


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build", help="the build directory (holds python/step_loop)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--threads", type=int, default=0, help="OpenMP threads (0: OpenMP's default)")
    a = ap.parse_args()
    exe = os.path.join(a.build, "python", "step_loop")
    print("sandmpm %s, sm_real %s, threads %s, %d rounds of %d steps after %d warm-up steps"
          % (sm.__version__, sm.real_dtype, a.threads or "default", a.rounds, a.steps, a.warmup))
    n, c, py, _ = compare(exe, "empty", a.rounds, 2000, 100, a.threads)
    fixed, _ = report("empty", n, c, py, "us", 1e6)
    n, c, py, adv = compare(exe, "block", a.rounds, a.steps, a.warmup, a.threads)
    report("block", n, c, py, "ms", 1e3)
    report("block, C loop in this process (sm_world_advance)", n, adv, py, "ms", 1e3)
    print("binding cost per step (empty world): %.2f us = %.4f%% of a %d-particle step (C median)"
          % (fixed * 1e6, 100 * fixed / statistics.median(c), n))


if __name__ == "__main__":
    main()
