"""Runs a Lua scene file from Python for several values of one of its parameters, with the outputs
`sandmpm run` writes (frames, run manifest, checkpoints, and renders with --render), then reads
the last frame back and renders it into a NumPy image.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/scene_sweep.py [--quality test] [--render]

For each friction angle of scenes/friction_angle.lua (20, 30, 40 degrees; the same as
`sandmpm run scenes/friction_angle.lua --set angle=A --out out/py_sweep/angle_A`): the pile's
height and runout (largest distance from the axis) at every frame, from the scene's world while
it runs (the per-frame callback), then the last frame's picture, out/py_sweep/angle_A/last.png.
"""
import argparse
import os

import numpy as np

import sandmpm as sm

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quality", default="test", help="preview, paper or test (default test: 2 frames)")
    ap.add_argument("--render", action="store_true", help="also write frame_NNNN.png, as sandmpm run --render")
    ap.add_argument("--out", default="out/py_sweep")
    args = ap.parse_args()
    scene_file = os.path.join(ROOT, "scenes", "friction_angle.lua")
    for angle in (20, 30, 40):
        out = os.path.join(args.out, "angle_%d" % angle)
        rows = []

        def on_frame(scene, frame):
            x = scene.world.positions  # a view, valid during the callback
            runout = np.hypot(x[:, 0], x[:, 2]).max()
            rows.append((frame, scene.world.time, x[:, 1].max() - 0.02, runout))

        with sm.load_scene(scene_file, quality=args.quality, angle=angle) as scene:
            result = scene.run(out, render=args.render, on_frame=on_frame, overwrite=True)
            camera = scene.settings  # the scene's camera table
        print("angle %d: %d frames in %s/" % (angle, result["frames_written"], out))
        for frame, t, height, runout in rows:
            print("  frame %3d  t = %.4f s  height %.4f m  runout %.4f m" % (frame, t, height, runout))
        last = sm.read_frame(os.path.join(out, "frame_%04d.ply" % rows[-1][0]))
        image = sm.render(last, width=640, height=360, color="speed", camera=camera,
                          ground=0.02)  # the scene's ground collider
        sm.write_png(os.path.join(out, "last.png"), image)
        print("  last frame: %d particles, rendered %s (coloured by speed) to %s/last.png"
              % (len(last), "x".join(map(str, image.shape)), out))


if __name__ == "__main__":
    main()
