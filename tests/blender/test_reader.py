"""The Blender add-on's frame reader (tools/blender/sandmpm_import.py), without Blender: PLY
parsing in every format sandmpm's reader accepts, y-up to z-up, particle radii."""
import math
import os
import struct
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools", "blender"))
import sandmpm_import as si  # noqa: E402

PROPS = [("x", "float", "f"), ("y", "float", "f"), ("z", "float", "f"), ("vx", "float", "f"),
         ("vy", "float", "f"), ("vz", "float", "f"), ("material", "ushort", "H"), ("q", "float", "f"),
         ("volume", "float", "f"), ("id", "uint", "I")]
ROWS = [(0.1, 0.2, 0.3, 1.0, -2.0, 0.5, 1, 0.25, 1e-6, 7), (-0.5, 0.75, 0.0, 0.0, 0.0, -1.0, 0, 0.0, 8e-6, 3)]


def write_ply(path, fmt, dim=3, extra_element=False, up=None, rows=ROWS):
    head = ["ply", f"format {fmt} 1.0", "comment sandmpm test", f"comment dim {dim}"]
    if up:
        head += [f"comment up {up}"]
    if extra_element:
        head += ["element camera 1", "property float fov"]
    head += [f"element vertex {len(rows)}"] + [f"property {t} {n}" for n, t, _ in PROPS] + ["end_header"]
    with open(path, "wb") as f:
        f.write(("\n".join(head) + "\n").encode())
        if fmt == "ascii":
            if extra_element:
                f.write(b"45\n")
            for r in rows:
                f.write((" ".join(repr(v) for v in r) + "\n").encode())
        else:
            o = "<" if fmt == "binary_little_endian" else ">"
            if extra_element:
                f.write(struct.pack(o + "f", 45.0))
            for r in rows:
                f.write(struct.pack(o + "".join(c for _, _, c in PROPS), *r))


@pytest.mark.parametrize("fmt", ["binary_little_endian", "binary_big_endian", "ascii"])
@pytest.mark.parametrize("extra", [False, True])
def test_read_every_format(tmp_path, fmt, extra):
    p = tmp_path / "frame_0000.ply"
    write_ply(p, fmt, extra_element=extra)
    fields, comments = si.read_ply(str(p))
    assert "dim 3" in comments
    for k, (name, _, _) in enumerate(PROPS):
        np.testing.assert_allclose(fields[name], [r[k] for r in ROWS], rtol=1e-6)
    assert fields["material"].dtype.kind == "u" and fields["id"].tolist() == [7, 3]


def test_z_up_and_attributes(tmp_path):
    p = tmp_path / "frame_0000.ply"
    write_ply(p, "binary_little_endian")
    pos, attrs = si.frame_arrays(str(p), z_up=True)
    # (x, y, z) -> (x, -z, y): sandmpm's up (y) is Blender's up (z)
    np.testing.assert_allclose(pos[0], [0.1, -0.3, 0.2], rtol=1e-6)
    np.testing.assert_allclose(attrs["velocity"][1][1], [0.0, 1.0, 0.0], rtol=1e-6)
    assert attrs["material"][0] == "INT" and attrs["id"][0] == "INT" and attrs["q"][0] == "FLOAT"
    # radius of the sphere of the particle's volume: V = 8e-6 m^3 -> r = (3V / 4 pi)^(1/3)
    np.testing.assert_allclose(attrs["radius"][1][1], (3 * 8e-6 / (4 * math.pi)) ** (1 / 3), rtol=1e-6)
    pos_y, _ = si.frame_arrays(str(p), z_up=False)
    np.testing.assert_allclose(pos_y[0], [0.1, 0.2, 0.3], rtol=1e-6)


def test_frames_written_z_up(tmp_path):
    """A run with outputs.up = "z" wrote (x, -z, y): imported z-up it lands where a y-up file does."""
    zrows = [(r[0], -r[2], r[1], r[3], -r[5], r[4]) + r[6:] for r in ROWS]
    py, pz = tmp_path / "y.ply", tmp_path / "z.ply"
    write_ply(py, "binary_little_endian", up="y")
    write_ply(pz, "binary_little_endian", up="z", rows=zrows)
    for z_up in (True, False):
        a, va = si.frame_arrays(str(py), z_up=z_up)
        b, vb = si.frame_arrays(str(pz), z_up=z_up)
        np.testing.assert_allclose(a, b, rtol=1e-6)
        np.testing.assert_allclose(va["velocity"][1], vb["velocity"][1], rtol=1e-6)
    pos, _ = si.frame_arrays(str(pz), z_up=True)
    np.testing.assert_allclose(pos[0], [0.1, -0.3, 0.2], rtol=1e-6)


def test_2d_radius_is_a_disk(tmp_path):
    p = tmp_path / "frame_0000.ply"
    write_ply(p, "binary_little_endian", dim=2)
    _, attrs = si.frame_arrays(str(p))
    np.testing.assert_allclose(attrs["radius"][1][1], math.sqrt(8e-6 / math.pi), rtol=1e-6)


def test_bad_files(tmp_path):
    p = tmp_path / "frame_0000.ply"
    p.write_bytes(b"not a ply file")
    with pytest.raises(si.PlyError, match="not a PLY"):
        si.read_ply(str(p))
    write_ply(p, "binary_little_endian")
    p.write_bytes(p.read_bytes()[:-5])
    with pytest.raises(si.PlyError, match="truncated"):
        si.read_ply(str(p))
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(si.PlyError, match="no frame_NNNN.ply"):
        si.frame_files(str(empty))


def test_frame_order(tmp_path):
    for n in (10, 2, 0):
        write_ply(tmp_path / f"frame_{n:04d}.ply", "ascii")
    (tmp_path / "frame_x.ply").write_text("ignored")
    assert [os.path.basename(f) for f in si.frame_files(str(tmp_path))] == [
        "frame_0000.ply", "frame_0002.ply", "frame_0010.ply"]


def test_frames_the_manifest_lists(tmp_path):
    for n in (0, 1, 2, 5):
        write_ply(tmp_path / f"frame_{n:04d}.ply", "ascii")
    (tmp_path / "run_manifest.txt").write_text("sandmpm-run 1\nscene x.lua\nstate complete\nframe_files ply 0 2\n"
                                               "frame_files vtp 0 2\n")
    # frame_0005.ply is not the listed run's: left out
    assert [os.path.basename(f) for f in si.frame_files(str(tmp_path))] == [
        "frame_0000.ply", "frame_0001.ply", "frame_0002.ply"]
