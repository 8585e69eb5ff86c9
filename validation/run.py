#!/usr/bin/python3
"""The validation study (docs/validation.md): runs the simulations, measures them, writes
out/validation/results.json; report.py turns that into the document and its plots.

usage: run.py [--quick] [--bin build-release/sandmpm] [--analytic build-release/tests/sm_validate]
              [--out out/validation] [--jobs 2] [--only GROUP[,GROUP...]]

Every simulation is a `sandmpm run` of a scene in validation/scenes/ with --set parameters; a run
whose output directory already holds a complete result for the same command and the same program
(SHA-256 of the binary) is not run again
(delete out/validation/runs to start over). --quick runs a coarse subset (minutes).
The analytic benchmarks (incline, elastic column, material-point shear) are subcommands of
sm_validate (validation/analytic.c), which prints CSV.
"""
import argparse
import concurrent.futures as cf
import hashlib
import json
import math
import os
import shlex
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import deposit  # noqa: E402

G = 9.81
FITS = ["triaxial_compression", "plane_strain", "inscribed", "simple_shear"]


def job(group, name, scene, **sets):
    return {"group": group, "name": name, "scene": scene, "sets": sets}


def collapse_jobs(quick):
    """The collapse matrix: (group, dim, aspect ratios, parameter sets)."""
    jobs = []
    if quick:
        a2 = [0.5, 2, 8]
        a3 = [1, 4]
        n2, n3 = 10, 6
    else:
        a2 = [0.5, 1, 2, 3, 4, 6, 8]
        a3 = [0.5, 1, 2, 4]
        n2, n3 = 12, 8
    fit_a2 = [a for a in a2 if a in (0.5, 1, 2, 4, 8)]
    fit_a3 = [a for a in a3 if a in (0.5, 1, 2, 4)]
    for fit in FITS:
        for a in (a2 if fit == FITS[0] else fit_a2):
            jobs.append(job("collapse2d", f"c2_{fit}_a{a}", "collapse2d.lua", a=a, n=n2, fit=fit))
        for a in (a3 if fit == FITS[0] else fit_a3):
            jobs.append(job("collapse3d", f"c3_{fit}_a{a}", "collapse3d.lua", a=a, n=n3, fit=fit))
    # base condition: Coulomb base (mu = 0.5) instead of sticky
    for fit in (FITS[0], FITS[3]):
        for a in (0.5, 2, 8):
            jobs.append(job("base2d", f"c2_{fit}_friction_a{a}", "collapse2d.lua", a=a, n=n2, fit=fit,
                            base="friction", base_mu=0.5))
    # convergence at a = 2 (2D): resolution, particles per cell, kernel, transfer; departures
    ref = dict(a=2, n=n2, fit=FITS[0])
    ns = [6, 10, 14] if quick else [6, 12, 24]
    for n in ns:
        jobs.append(job("conv2d", f"c2_conv_n{n}", "collapse2d.lua", **dict(ref, n=n)))
    variants = [("ppc16", dict(ppc=16)), ("cubic", dict(kernel="cubic")), ("pic", dict(transfer="pic")),
                ("flip", dict(transfer="flip")), ("noproj", dict(projection=False)),
                ("nosticks", dict(sticks=False))]
    for tag, extra in variants:
        jobs.append(job("conv2d", f"c2_conv_{tag}", "collapse2d.lua", **dict(ref, **extra)))
    n3s = [4, 6, 8] if quick else [5, 8, 11]
    for n in n3s:
        jobs.append(job("conv3d", f"c3_conv_n{n}", "collapse3d.lua", a=2, n=n, fit=FITS[0]))
    return jobs


def pile_jobs(quick):
    """Repose angle of poured piles (validation/scenes/pile.lua), heaps let go (heap.lua), and the
    experiments on the poured pile, one change at a time (n = cells per 6 mm)."""
    jobs = []
    n2, n3 = (2, 1) if quick else (4, 2)
    for phi in ((30,) if quick else (20, 30, 40)):
        jobs.append(job("pile", f"pile2_{FITS[0]}_phi{phi}", "pile.lua", dim=2, fit=FITS[0], phi=phi, n=n2))
    for fit in (FITS[0], FITS[3]):
        if fit != FITS[0]:
            jobs.append(job("pile", f"pile2_{fit}_phi30", "pile.lua", dim=2, fit=fit, phi=30, n=n2))
        jobs.append(job("pile", f"pile3_{fit}_phi30", "pile.lua", dim=3, fit=fit, phi=30, n=n3))
    # why the thesis's pile is flat (3D, phi 30, the thesis's fit)
    base = dict(dim=3, fit=FITS[0], phi=30, n=n3)
    for tag, extra in [("finer", dict(n=n3 + 1)), ("slow", dict(speed=0.1, drop=0.025)),
                       ("noproj", dict(projection=False)), ("pic", dict(transfer="pic")),
                       ("slipbase", dict(base="friction", base_mu=0.7))]:
        jobs.append(job("pilexp", f"pile3_exp_{tag}", "pile.lua", **dict(base, **extra)))
    # 2D: the poured pile at two more resolutions, and a heap let go from 45 degrees (no stream)
    for nn in ((1, 3) if quick else (2, 6)):
        jobs.append(job("pilexp", f"pile2_exp_n{nn}", "pile.lua", dim=2, fit=FITS[0], phi=30, n=nn))
    for nn in ((1, 2, 3) if quick else (2, 4, 8)):
        jobs.append(job("heap", f"heap2_n{nn}", "heap.lua", fit=FITS[0], phi=30, n=nn))
    hn = 2 if quick else 4
    for tag, extra in [("ss", dict(fit=FITS[3])), ("noproj", dict(projection=False)), ("pic", dict(transfer="pic")),
                       ("slope35", dict(slope=35)), ("friction", dict(base="friction", base_mu=0.7))]:
        jobs.append(job("heap", f"heap2_{tag}", "heap.lua", **dict(dict(fit=FITS[0], phi=30, n=hn), **extra)))
    return jobs


def command(binary, j, out):
    cmd = [binary, "run", os.path.join(HERE, "scenes", j["scene"]), "--threads", "1", "--out", out]
    for k, v in sorted(j["sets"].items()):
        v = ("true" if v else "false") if isinstance(v, bool) else v
        cmd += ["--set", f"{k}={v}"]
    return cmd


_digests = {}


def binary_digest(path):
    """SHA-256 of the program file (computed once per run.py)."""
    if path not in _digests:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
        _digests[path] = h.hexdigest()
    return _digests[path]


def source_commit():
    """The commit of the tree the runs are made from (git describe; '-dirty' with local changes)."""
    r = subprocess.run(["git", "-C", os.path.join(HERE, ".."), "describe", "--always", "--dirty"],
                       stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    return r.stdout.strip() or "unknown"


def machine():
    """CPU model and core count, from /proc/cpuinfo and os.cpu_count()."""
    model = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} logical cores"


def run_one(binary, j, root):
    out = os.path.join(root, "runs", j["name"])
    cmd = command(binary, j, out)
    stamp = os.path.join(out, "command.txt")
    # A run is reused only for the same command AND the same program (its SHA-256): results are
    # deterministic, so the same binary gives the same frames; a rebuilt program redoes the runs.
    key = shlex.join(cmd) + "\n" + binary_digest(binary)
    if os.path.exists(stamp) and open(stamp).read() == key:
        return j["name"], 0.0, True
    t0 = time.time()
    # --overwrite (not in the key): the folder is this job's, an earlier run in it (of an edited
    # scene, or by an older program without run_manifest.txt) is replaced
    r = subprocess.run(cmd + ["--overwrite"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{j['name']}: exit {r.returncode}: {r.stderr[-800:]}")
    with open(stamp, "w") as f:
        f.write(key)
    with open(os.path.join(out, "commit.txt"), "w") as f:
        f.write(source_commit() + "\n" + machine() + "\n")
    return j["name"], time.time() - t0, False


def run_provenance(jobs, root):
    """How many runs were made at which commit on which machine (runs cached from before this was
    recorded count as 'unrecorded')."""
    seen = {}
    for j in jobs:
        try:
            commit, mach = open(os.path.join(root, "runs", j["name"], "commit.txt")).read().splitlines()[:2]
        except (OSError, ValueError):
            commit, mach = "unrecorded", "unrecorded"
        key = f"{commit} on {mach}"
        seen[key] = seen.get(key, 0) + 1
    return seen


def frames(out):
    return sorted(f for f in os.listdir(out) if f.startswith("frame_") and f.endswith(".ply"))


def analyse_collapse(j, root):
    out = os.path.join(root, "runs", j["name"])
    s = j["sets"]
    dim = 3 if j["scene"] == "collapse3d.lua" else 2
    a = float(s["a"])
    size0 = 0.05
    n = s["n"]
    dx = size0 / n
    ppc = s.get("ppc", 8 if dim == 3 else 4)
    H0 = a * size0
    fr = frames(out)
    diag = deposit.read_csv(os.path.join(out, "diagnostics.csv"))
    fronts, heights = [], []
    for f in fr:
        m = deposit.measure(deposit.read_ply(os.path.join(out, f)), dx, ppc, axisymmetric=(dim == 3))
        fronts.append(m["front"])
        heights.append(m["height"])
    t = diag["time_s"]
    final = fronts[-1]
    # flow duration: first frame time the front is within 2% of its final advance (and stays)
    adv = final - size0
    tstop = t[-1]
    for i in range(len(fronts)):
        if all(abs(final - fronts[k]) <= 0.02 * adv for k in range(i, len(fronts))):
            tstop = t[i]
            break
    ke = diag["kinetic_energy_J"]
    return {
        "dim": dim, "a": a, "n": n, "ppc": ppc, "sets": s,
        "runout": (final - size0) / size0,
        "height": heights[-1] / size0,
        "front0": fronts[0] / size0, "height0": heights[0] / size0,
        "t_flow": float(tstop), "tau": math.sqrt(H0 / G),
        "ke_end_rel": float(ke[-1] / ke.max()) if ke.max() > 0 else 0.0,
        "series": {"t": [float(x) for x in t], "front": [f / size0 for f in fronts], "height": [h / size0 for h in heights]},
        "wall_s": float(diag["wall_s_total"][-1]),
        "steps": int(diag["steps_total"][-1]),
    }


def analyse_pile(j, root):
    out = os.path.join(root, "runs", j["name"])
    last = frames(out)[-1]
    p = deposit.read_ply(os.path.join(out, last))
    s = j["sets"]
    dim = s.get("dim", 2 if j["scene"] == "heap.lua" else 3)
    dx = pile_dx(s)
    ppc = s.get("ppc", 8 if dim == 3 else 4)
    ang = deposit.flank_angle(p, dx, ppc, axisymmetric=(dim == 3))
    diag = deposit.read_csv(os.path.join(out, "diagnostics.csv"))
    return dict(ang, dim=dim, sets=s, ke_end=float(diag["kinetic_energy_J"][-1]),
                wall_s=float(diag["wall_s_total"][-1]), steps=int(diag["steps_total"][-1]))


def pile_dx(s):
    return 0.006 / s.get("n", 4)


def run_analytic(binary, quick, root):
    """sm_validate subcommands; each prints CSV with a header line, kept in ROOT/analytic_SUB.csv
    (reused while the command and the binary are unchanged)."""
    res = {}
    for sub in ["incline", "incline_gate", "incline_stiffness", "incline_resolution", "column", "shear"]:
        args = [binary, sub] + (["--quick"] if quick else [])
        path = os.path.join(root, f"analytic_{sub}.csv")
        key = shlex.join(args) + " " + binary_digest(binary) + "\n"
        if os.path.exists(path) and open(path).readline() == key:
            text = open(path).read().split("\n", 1)[1]
        else:
            r = subprocess.run(args, capture_output=True, text=True)
            if r.returncode != 0:
                raise RuntimeError(f"sm_validate {sub}: exit {r.returncode}: {r.stderr[-800:]}")
            text = r.stdout
            with open(path, "w") as f:
                f.write(key + text)
            print(f"sm_validate {sub}: done", flush=True)
        lines = [line for line in text.splitlines() if line and not line.startswith("#")]
        head = lines[0].split(",")
        rows = []
        for line in lines[1:]:
            vals = line.split(",")
            rows.append({h: (float(v) if _isnum(v) else v) for h, v in zip(head, vals)})
        res[sub] = rows
    return res


def _isnum(v):
    try:
        float(v)
        return True
    except ValueError:
        return False


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--bin", default="build-release/sandmpm")
    ap.add_argument("--analytic", default="build-release/tests/sm_validate")
    ap.add_argument("--out", default="out/validation")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="")
    ap.add_argument("--analytic-only", action="store_true", help="only the sm_validate benchmarks (cached)")
    args = ap.parse_args()
    root = os.path.join(args.out, "quick" if args.quick else "full")
    os.makedirs(os.path.join(root, "runs"), exist_ok=True)
    if args.analytic_only:
        run_analytic(args.analytic, args.quick, root)
        return
    jobs = collapse_jobs(args.quick) + pile_jobs(args.quick)
    if args.only:
        keep = set(args.only.split(","))
        jobs = [j for j in jobs if j["group"] in keep]
    t0 = time.time()
    # the expensive ones first, so the two workers finish together
    order = sorted(jobs, key=lambda j: -cost_guess(j))
    with cf.ThreadPoolExecutor(max_workers=args.jobs) as ex:
        futs = [ex.submit(run_one, args.bin, j, root) for j in order]
        for k, fu in enumerate(cf.as_completed(futs)):
            name, secs, cached = fu.result()
            print(f"[{k + 1}/{len(jobs)}] {name}: {'cached' if cached else f'{secs:.0f} s'}", flush=True)
    results = {"quick": args.quick, "collapse": {}, "pile": {}}
    for j in jobs:
        if j["scene"].startswith("collapse"):
            results["collapse"][j["name"]] = dict(analyse_collapse(j, root), group=j["group"])
        else:
            results["pile"][j["name"]] = dict(analyse_pile(j, root), group=j["group"])
    if not args.only:
        results["analytic"] = run_analytic(args.analytic, args.quick, root)
    results["wall_seconds"] = time.time() - t0
    results["provenance"] = run_provenance(jobs, root)
    results["report_machine"] = machine()
    with open(os.path.join(root, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    print(f"run.py: {len(jobs)} simulations, results in {root}/results.json ({time.time() - t0:.0f} s)")


def cost_guess(j):
    s = j["sets"]
    a = float(s.get("a", 1))
    n = float(s.get("n", 10))
    if j["scene"] == "collapse3d.lua":
        return a ** 1.5 * n ** 4 * 8
    if j["scene"] == "collapse2d.lua":
        return a ** 1.5 * n ** 3 * s.get("ppc", 4)
    if j["scene"] == "heap.lua":
        return 3e3 * n ** 3
    return 1e7 * n ** 4 / 1296.0 * (3 if s.get("dim") == 3 else 0.3)


if __name__ == "__main__":
    main()
