"""The worlds of tests/python/pyref.c, built through the Python package (keep the two in step)."""
import math

import sandmpm as sm

PLATE_X0, PLATE_Y0, PLATE_V, PLATE_HALF_W = 0.285, 0.2, 0.5, 0.01


def column(dim, dx):
    """A sand column (cylinder, r 0.1, half height 0.15, centred at (0.5, 0.25, 0.5)) on a sticky
    ground at y = 0.1."""
    w = sm.World(dim=dim, dx=dx)
    sand = sm.Material.sand()
    w.add_collider(sm.Collider(sm.Shape.halfspace((0, 0.1, 0), (0, 1, 0))))
    w.seed(sm.Shape.cylinder((0.5, 0.25, 0.5), radius=0.1, half_height=0.15), sand, ppc=8)
    return w


def step_adaptive(w, n):
    for _ in range(n):
        w.step()


def plate(motion=None):
    """A 2D sand layer (x 0.3..0.7, y 0.1..0.2) on a sticky ground, and a sticky plate at
    x = 0.285 (its face touching the sand) moving +x at 0.5 m/s: constant velocity, or the callable `motion` if given."""
    w = sm.World(dim=2, dx=0.01)
    sand = sm.Material.sand()
    w.add_collider(sm.Collider(sm.Shape.halfspace((0, 0.1, 0), (0, 1, 0))))
    box = sm.Shape.box((0, 0, 0), (PLATE_HALF_W, 0.1, 0))
    if motion is None:
        pid = w.add_collider(sm.Collider(box, position=(PLATE_X0, PLATE_Y0, 0), velocity=(PLATE_V, 0, 0)))
    else:
        pid = w.add_collider(sm.Collider(box, position=(PLATE_X0, PLATE_Y0, 0), motion=motion))
    w.seed(sm.Shape.box((0.5, 0.15, 0), (0.2, 0.05, 0)), sand, ppc=4)
    return w, pid


def plate_motion(t):
    return (PLATE_X0 + PLATE_V * t, PLATE_Y0)


def front_velocity(w, pid, dx=0.01):
    """Mean x velocity of the particles within 2 dx in front of the plate face (summed in storage
    order in double precision, as pyref.c does), and their count."""
    face = w.collider_pose(pid)[0][0] + PLATE_HALF_W
    x, v = w.positions, w.velocities
    total, count = 0.0, 0
    for i in range(len(w)):
        xi = float(x[i, 0])
        if face < xi < face + 2 * dx:
            total += float(v[i, 0])
            count += 1
    return (total / count if count else 0.0), count


def hexhash(w):
    return "%016x" % w.state_hash()


def isclose(a, b, rel):
    return math.isclose(a, b, rel_tol=rel)
