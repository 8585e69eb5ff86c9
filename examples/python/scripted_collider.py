"""A plate driven by a Python function ploughs through a sand bed.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/scripted_collider.py

The plate (a thin box, sticky) enters the bed at 0.4 m/s, tilts back by 20 degrees while it moves,
and stops at t = 0.4 s; motion(t) returns its position and rotation, as a scene's Lua motion
function does. Per frame: the plate's pose, the sand pushed ahead of it and the sand's momentum.
"""
import math

import numpy as np

import sandmpm as sm

SPEED, STOP, TILT = 0.4, 0.4, 20.0


def motion(t):
    s = min(t, STOP)
    position = (0.25 + SPEED * s, 0.22)
    rotation = sm.axis_angle((0, 0, 1), TILT * s / STOP)
    return position, rotation


def main():
    with sm.World(dim=2, dx=0.01) as w:
        sand = sm.Material.sand()
        w.add_collider(sm.Collider(sm.Shape.halfspace((0, 0.1), (0, 1)), mode="slip", friction=0.5))
        plate = w.add_collider(sm.Collider(sm.Shape.box((0, 0), (0.01, 0.08)), motion=motion))
        w.seed(sm.Shape.box((0.55, 0.15), (0.25, 0.05)), sand, ppc=4)

        def report(world, frame):
            (px, py, _), q = world.collider_pose(plate)
            x, v = world.positions, world.velocities
            ahead = x[:, 0] > px + 0.01
            moving = np.linalg.norm(v, axis=1) > 0.05
            d = world.diagnostics()
            print("frame %2d  t %.3f  plate x %.3f tilt %5.1f deg  moving sand %4d of %d  p_x %+.4f kg m/s"
                  % (frame, world.time, px, math.degrees(2 * math.atan2(q[3], q[0])),
                     int(np.count_nonzero(ahead & moving)), len(world), d["momentum"][0]))

        w.run(12, 24, on_frame=report)


if __name__ == "__main__":
    main()
