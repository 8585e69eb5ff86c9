#!/usr/bin/python3
"""The collapse's deposit against the time step at a fixed grid (docs/validation.md, section 9,
"Time step"): validation/scenes/collapse2d.lua / collapse3d.lua (a = 2, thesis fit, sticky base)
run with `--set elastic_cfl=...` at several values, the final frame measured as the validation
study does (validation/deposit.py).

usage: /usr/bin/python3 docs/experiments/collapse_dt.py SANDMPM DIM N TRANSFER CFL [CFL ...] [KEY=VALUE ...]
  e.g. docs/experiments/collapse_dt.py build-release/sandmpm 2 12 apic 0.5 0.25 0.125
  KEY=VALUE: more scene parameters for every run (e.g. base=friction sticks=false)
Prints one line per run: steps, runout (L_inf - L0)/L0, height H_inf/L0, wall time.
"""
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
sys.path.insert(0, os.path.join(ROOT, "validation"))
import deposit  # noqa: E402

L0 = 0.05  # the scenes' default column length (m)


def run(binary, dim, n, transfer, cfl, extra):
    scene = os.path.join(ROOT, "validation", "scenes", f"collapse{dim}d.lua")
    out = tempfile.mkdtemp(prefix="collapse_dt_")
    try:
        subprocess.run([binary, "run", scene, "--set", "a=2", "--set", f"n={n}", "--set", f"transfer={transfer}",
                        "--set", f"elastic_cfl={cfl}", *[a for kv in extra for a in ("--set", kv)],
                        "--checkpoint-every", "0", "-q", "--out", out + "/o"], check=True)
        o = out + "/o"
        last = sorted(f for f in os.listdir(o) if f.startswith("frame_") and f.endswith(".ply"))[-1]
        m = deposit.measure(deposit.read_ply(os.path.join(o, last)), L0 / n, 8 if dim == 3 else 4,
                            axisymmetric=(dim == 3))
        d = deposit.read_csv(os.path.join(o, "diagnostics.csv"))
        print(f"{dim}D n={n} {transfer} elastic_cfl={cfl} {' '.join(extra)}: steps {int(d['steps_total'][-1])}, "
              f"runout {(m['front'] - L0) / L0:.3f}, height {m['height'] / L0:.3f}, wall {d['wall_s_total'][-1]:.1f} s",
              flush=True)
    finally:
        shutil.rmtree(out)


def main():
    if len(sys.argv) < 6:
        sys.exit(__doc__)
    binary, dim, n, transfer = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    extra = [a for a in sys.argv[5:] if "=" in a]
    for cfl in (a for a in sys.argv[5:] if "=" not in a):
        run(binary, dim, n, transfer, float(cfl), extra)


if __name__ == "__main__":
    main()
