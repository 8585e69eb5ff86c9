"""Overhead of a Python World.step() loop against the same loop in C (python/bench/step_loop.c).

    PYTHONPATH=build/python /usr/bin/python3 python/bench/step_overhead.py build [--rounds 5] [--steps 20] [--threads 1]

Runs both loops on the same 3D scene of about 100k particles (step_loop.c's "block"), alternating
C and Python, ROUNDS times each, and prints per-step times (minimum and median over the rounds),
as wall time and as the process's CPU time (with --threads 1 the CPU time counts only this loop's
work, so it is much less disturbed by other programs on the machine than wall time is). A third
line times the C loop inside this process (sm_world_advance over the same simulated time), which
removes the difference between two processes. Both loops must end with the same state hash.

On a shared machine two runs of the same simulation differ by more than the binding costs, so the
binding's cost is also measured directly: the same loops on the world without particles
("empty"), where a step costs almost nothing but the call itself. Not a test: a benchmark
(docs/python.md, "Overhead").
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


def clocks():
    return time.perf_counter(), time.process_time()


def python_loop(scene, steps, warmup, threads):
    with build(scene == "block", threads) as w:
        for _ in range(warmup):
            w.step()
        t0, c0 = clocks()
        for _ in range(steps):
            w.step()
        t1, c1 = clocks()
        return {"particles": len(w), "wall": (t1 - t0) / steps, "cpu": (c1 - c0) / steps,
                "hash": "%016x" % w.state_hash()}


def advance_loop(scene, steps, warmup, threads):
    """The C loop inside this process: sm_world_advance (next_dt + step in C) over the simulated
    time that `steps` steps cover; per step = time / the number of steps advance took."""
    with build(scene == "block", threads) as probe:  # how far warmup + steps adaptive steps go
        for _ in range(warmup + steps):
            probe.step()
        t_end = probe.time
    with build(scene == "block", threads) as w:
        for _ in range(warmup):
            w.step()
        s0 = w.diagnostics()["steps"]
        t0, c0 = clocks()
        sm.lib.sm_world_advance(w._w, t_end)
        t1, c1 = clocks()
        n = max(1, w.diagnostics()["steps"] - s0)
        return {"wall": (t1 - t0) / n, "cpu": (c1 - c0) / n}


def c_loop(exe, scene, steps, warmup, threads):
    out = subprocess.run([exe, scene, str(steps), str(warmup), str(threads)], check=True, capture_output=True,
                         text=True).stdout
    r = dict(line.split() for line in out.splitlines())
    return {"particles": int(r["particles"]), "wall": float(r["seconds_per_step"]),
            "cpu": float(r["cpu_seconds_per_step"]), "hash": r["hash"]}


def compare(exe, scene, rounds, steps, warmup, threads, in_process):
    runs = {"C": [], "Python": [], "C in-process": []}
    for _ in range(rounds):
        rc = c_loop(exe, scene, steps, warmup, threads)
        rp = python_loop(scene, steps, warmup, threads)
        if rc["hash"] != rp["hash"] or rc["particles"] != rp["particles"]:
            sys.exit("step_overhead: the C and Python loops did not simulate the same thing (%s vs %s)" % (rc, rp))
        runs["C"].append(rc)
        runs["Python"].append(rp)
        if in_process:
            runs["C in-process"].append(advance_loop(scene, steps, warmup, threads))
    return rc["particles"], runs


def summary(runs, key):
    values = [r[key] for r in runs]
    return min(values), statistics.median(values)


def report(title, n, runs, unit, scale):
    print("%s (%d particles), per step in %s: min / median over the rounds" % (title, n, unit))
    py = {k: summary(runs["Python"], k) for k in ("wall", "cpu")}
    for name in ("C", "C in-process"):
        if not runs[name]:
            continue
        for key in ("wall", "cpu"):
            c = summary(runs[name], key)
            print("  %-4s %-13s %10.3f / %10.3f   Python %10.3f / %10.3f   Python - C: %+.3f (%+.2f%%) / %+.3f (%+.2f%%)"
                  % (key, name, c[0] * scale, c[1] * scale, py[key][0] * scale, py[key][1] * scale,
                     (py[key][0] - c[0]) * scale, 100 * (py[key][0] - c[0]) / c[0],
                     (py[key][1] - c[1]) * scale, 100 * (py[key][1] - c[1]) / c[1]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build", help="the build directory (holds python/step_loop)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1, help="threads of the step (0: the library chooses)")
    a = ap.parse_args()
    exe = os.path.join(a.build, "python", "step_loop")
    print("sandmpm %s, sm_real %s, threads %s, %d rounds of %d steps after %d warm-up steps; load average %s"
          % (sm.__version__, sm.real_dtype, a.threads or "default", a.rounds, a.steps, a.warmup,
             " ".join("%.1f" % x for x in os.getloadavg())))
    n, runs = compare(exe, "empty", a.rounds, 20000, 100, a.threads, False)
    report("empty world", n, runs, "us", 1e6)
    fixed = summary(runs["Python"], "cpu")[0] - summary(runs["C"], "cpu")[0]
    n, runs = compare(exe, "block", a.rounds, a.steps, a.warmup, a.threads, True)
    report("block", n, runs, "ms", 1e3)
    step = summary(runs["C"], "cpu")[1]
    print("binding cost per step (empty world, CPU, min): %.2f us = %.4f%% of a %d-particle step (C, CPU, median %.1f ms)"
          % (fixed * 1e6, 100 * fixed / step, n, step * 1e3))


if __name__ == "__main__":
    main()
