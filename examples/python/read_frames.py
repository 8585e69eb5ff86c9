"""Reads the frames that `sandmpm run` wrote (binary PLY) back into NumPy, for analysis.

    build/sandmpm run --quality test --out out/default
    PYTHONPATH=build/python /usr/bin/python3 examples/python/read_frames.py out/default

For each frame_NNNN.ply: the particle count, the pile's height and radius (about its mean x, z), the mean speed, and the
mean friction angle (it grows with the hardening state q, thesis 3.79). read_ply() returns a NumPy
structured array with the PLY's properties (x, y, z, vx, vy, vz, material, q, friction_angle,
Je, volume, id; vertices in id order, so row k is the same grain in every frame) and the header's
comments. (Needs only NumPy; the package is not used.)
"""
import glob
import os
import sys

import numpy as np

_TYPES = {"float": "<f4", "double": "<f8", "uchar": "u1", "ushort": "<u2", "int": "<i4", "uint": "<u4"}


def read_ply(path):
    """(records, comments) of a binary little-endian PLY with one vertex element."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError("%s: not a PLY file" % path)
        fields, comments, count = [], [], None
        while True:
            line = f.readline()
            if not line:
                raise ValueError("%s: no end_header" % path)
            words = line.decode("ascii").split()
            if not words:
                continue
            if words[0] == "format" and words[1] != "binary_little_endian":
                raise ValueError("%s: format %s is not read here" % (path, words[1]))
            elif words[0] == "comment":
                comments.append(" ".join(words[1:]))
            elif words[0] == "element":
                if words[1] != "vertex":
                    raise ValueError("%s: element %s is not read here" % (path, words[1]))
                count = int(words[2])
            elif words[0] == "property":
                fields.append((words[2], _TYPES[words[1]]))
            elif words[0] == "end_header":
                break
        data = np.fromfile(f, dtype=np.dtype(fields), count=count)
    if len(data) != count:
        raise ValueError("%s: %d of %d vertices" % (path, len(data), count))
    return data, comments


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    frames = sorted(glob.glob(os.path.join(sys.argv[1], "frame_*.ply")))
    if not frames:
        sys.exit("no frame_*.ply in %s" % sys.argv[1])
    print("frame  particles  height_m  radius_m  mean_speed  mean_phi_deg")
    for path in frames:
        p, comments = read_ply(path)
        dim = int(next(c.split()[1] for c in comments if c.startswith("dim")))
        cx, cz = p["x"].mean(), p["z"].mean()  # the pile's axis
        r = np.hypot(p["x"] - cx, p["z"] - cz) if dim == 3 else np.abs(p["x"] - cx)
        speed = np.sqrt(p["vx"] ** 2 + p["vy"] ** 2 + p["vz"] ** 2)
        print("%5s  %9d  %8.4f  %8.4f  %10.4f  %12.2f"
              % (os.path.basename(path)[6:10], len(p), p["y"].max() - p["y"].min(), r.max(), speed.mean(),
                 p["friction_angle"].mean()))


if __name__ == "__main__":
    main()
