#!/usr/bin/python3
"""The reduced subset of the validation study (docs/validation.md), a CTest test:
test_validation_collapse.py SANDMPM SOURCE_DIR

1. 2D column collapses (validation/scenes/collapse2d.lua) at a = 2 and a = 8, coarse (L0/dx = 8),
   with the thesis's cone fit and with the simple-shear fit; the normalised runout (L∞ − L0)/L0,
   measured as validation/deposit.py defines it, must lie within a stated band around the law of
   Lube et al. 2005 (1.2 a below a = 2.3, 1.9 a^(2/3) above), as a ratio simulated/law:
     thesis fit (triaxial compression): [1.00, 2.00]  — it runs out too far in 2D (mu_eff = 0.462);
     simple-shear fit:                   [0.70, 1.35]  — mu_eff = tan 30 deg, close to the experiments;
   and the simple-shear fit must run out less than the thesis's fit at both a.
   The bands: measured here (L0/dx = 8) 1.21 and 1.54 (thesis fit, a = 2 and 8) and 0.94 and 1.17
   (simple shear); the full study (L0/dx = 12, docs/validation.md) gives 1.52 and 1.65, and 1.04 and
   1.19 (both with the front's threshold of 0.75 s, since 2026-12-03; with s they were 1.15, 1.45,
   0.88, 1.10 here). The bands hold both resolutions with a margin of at least 0.15, which also covers the
   float and double builds taking different paths through the same flow; the runout grows with resolution (docs/validation.md, section 8), so the
   bands are for this resolution, not statements about converged runouts.
2. repose_angle reaches the library through the loader: a 2D pile with repose_angle = 30 and each
   cone fit has particles whose friction angle (PLY) is the fit's inverse of mu_eff = tan 30°; a
   repose angle the fit cannot reach (plane strain, 50°) is refused with exit code 2.
Needs numpy (Debian's python3-numpy, scripts/install-deps.sh)."""
import math
import os
import subprocess
import sys
import tempfile

BIN, SRC = sys.argv[1], sys.argv[2]
sys.path.insert(0, os.path.join(SRC, "validation"))
import deposit  # noqa: E402

failures = 0


def check(ok, what):
    global failures
    print(("ok   " if ok else "FAIL ") + what)
    failures += 0 if ok else 1


def run(scene, out, **sets):
    cmd = [BIN, "run", os.path.join(SRC, "validation", "scenes", scene), "--threads", "1", "--out", out]
    for k, v in sets.items():
        cmd += ["--set", f"{k}={v}"]
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        print(r.stderr[-2000:])
        sys.exit(1)


def lube2005(a):
    return 1.2 * a if a < 2.3 else 1.9 * a ** (2 / 3)


BANDS = {"triaxial_compression": (1.00, 2.00), "simple_shear": (0.70, 1.35)}
N = 8
with tempfile.TemporaryDirectory() as tmp:
    runout = {}
    for fit, (lo, hi) in BANDS.items():
        for a in (2, 8):
            out = os.path.join(tmp, f"{fit}_{a}")
            run("collapse2d.lua", out, a=a, n=N, fit=fit)
            last = sorted(f for f in os.listdir(out) if f.endswith(".ply"))[-1]
            m = deposit.measure(deposit.read_ply(os.path.join(out, last)), 0.05 / N, 4)
            ro = (m["front"] - 0.05) / 0.05
            runout[fit, a] = ro
            ratio = ro / lube2005(a)
            check(lo <= ratio <= hi, f"2D collapse a = {a}, {fit}: (L-L0)/L0 = {ro:.2f}, Lube 2005 {lube2005(a):.2f}, "
                  f"ratio {ratio:.2f} in [{lo}, {hi}]")
    for a in (2, 8):
        check(runout["simple_shear", a] < runout["triaxial_compression", a],
              f"a = {a}: the simple-shear fit runs out less than the thesis's")
    # repose_angle -> friction angle per fit, 2D
    c = math.sqrt(2 / 3)
    mu = math.tan(math.radians(30))
    alpha = mu / math.sqrt(2)  # 2D: mu_eff = sqrt(2) alpha
    expect = {
        "triaxial_compression": math.degrees(math.asin(3 * alpha / (2 * c + alpha))),
        "plane_strain": math.degrees(math.asin(mu)),
        "simple_shear": 30.0,
        "plane_strain/50": None,  # tan 50 deg > 1 = the plane-strain fit's largest mu_eff: an error
    }
    for key, want in expect.items():
        fit, theta = (key.split("/") + ["30"])[:2]
        out = os.path.join(tmp, f"pile_{fit}_{theta}")
        cmd = [BIN, "run", os.path.join(SRC, "validation", "scenes", "pile.lua"), "--quality", "test", "--end", "0.02",
               "--set", "dim=2", "--set", f"repose={theta}", "--set", f"fit={fit}", "--out", out]
        r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if want is None:
            check(r.returncode == 2 and "repose_angle" in r.stderr, f"repose_angle {theta} with {fit} in 2D is refused: "
                  f"{r.stderr.strip().splitlines()[-1] if r.stderr.strip() else ''}")
            continue
        if r.returncode != 0:
            check(False, f"pile with repose_angle, {fit}: exit {r.returncode}: {r.stderr[-500:]}")
            continue
        last = sorted(f for f in os.listdir(out) if f.endswith(".ply"))[-1]
        p = deposit.read_ply(os.path.join(out, last))
        got = p["friction_angle"]
        check(len(got) > 0 and abs(got.max() - want) < 1e-4 and abs(got.min() - want) < 1e-4,
              f"repose_angle 30, {fit}, 2D: friction angle {got.min() if len(got) else float('nan'):.5f}, expected {want:.5f}")
print(f"test_validation_collapse: {failures} failed")
sys.exit(1 if failures else 0)
