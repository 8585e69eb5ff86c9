"""Runout of a collapsing sand column against the friction angle (a parameter study).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/friction_sweep.py [--angles 20,25,30,35,40] [--out runout.png]

A 2D column (width 0.1 m, height 0.2 m) of sand with a fixed friction angle collapses on a sticky
ground; the runout is how far the pile's toe (the 99th percentile of the particles' distance from
the axis, so that a few stray grains do not count) gets beyond the column's half width, after 1 s.
Lower friction angles spread further. Prints a table; with python3-matplotlib installed, also
plots runout against angle to --out.
"""
import argparse

import numpy as np

import sandmpm as sm

HALF_WIDTH, HEIGHT, GROUND, AXIS = 0.05, 0.2, 0.1, 1.0


def runout(angle, dx=0.01, end=1.0):
    with sm.World(dim=2, dx=dx, domain_max=(2 * AXIS, 0.5)) as w:
        sand = sm.Material.sand(hardening=False, friction_angle=angle)
        w.add_collider(sm.Collider(sm.Shape.halfspace((0, GROUND), (0, 1))))
        w.seed(sm.Shape.box((AXIS, GROUND + HEIGHT / 2), (HALF_WIDTH, HEIGHT / 2)), sand, ppc=4)
        w.advance(end)
        toe = np.percentile(np.abs(w.positions[:, 0] - AXIS), 99)
        height = np.percentile(w.positions[:, 1], 99) - GROUND
        return toe - HALF_WIDTH, height, w.diagnostics()["kinetic_energy"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--angles", default="20,25,30,35,40")
    ap.add_argument("--out", default="runout.png")
    a = ap.parse_args()
    angles = [float(s) for s in a.angles.split(",")]
    rows = []
    print("angle_deg  runout_m  height_m  kinetic_J")
    for phi in angles:
        r, h, ke = runout(phi)
        rows.append((phi, r, h))
        print("%9.1f  %8.4f  %8.4f  %9.2e" % (phi, r, h, ke))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(python3-matplotlib is not installed: no plot)")
        return
    data = np.array(rows)
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(data[:, 0], data[:, 1] / HEIGHT, "o-")
    ax.set_xlabel("friction angle (degrees)")
    ax.set_ylabel("runout / initial height")
    ax.set_title("2D column collapse, aspect ratio %.0f" % (HEIGHT / (2 * HALF_WIDTH)))
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
