#!/usr/bin/python3
"""Writes the PLY seed corpus (tests/fuzz/corpus/ply/) from frames of `sandmpm run --quality test`:
each frame trimmed to a few vertices, in the three formats (binary little- and big-endian, ascii),
plus hand-made edge cases. Usage: make_ply_seeds.py OUTDIR FRAME.ply..."""
import struct
import sys

SIZES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
         "float": "f", "double": "d", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H",
         "int32": "i", "uint32": "I", "float32": "f", "float64": "d"}


def parse(data):
    end = data.index(b"end_header\n") + len(b"end_header\n")
    lines = data[:end].decode().splitlines()
    props = [(l.split()[1], l.split()[2]) for l in lines if l.startswith("property ")]
    comments = [l for l in lines if l.startswith("comment ")]
    n = int([l for l in lines if l.startswith("element vertex")][0].split()[2])
    fmt = "<" + "".join(SIZES[t] for t, _ in props)
    stride = struct.calcsize(fmt)
    rows = [struct.unpack_from(fmt, data, end + i * stride) for i in range(n)]
    return props, comments, rows


def write(path, fmt_name, props, comments, rows):
    head = ["ply", "format %s 1.0" % fmt_name] + comments + ["element vertex %d" % len(rows)]
    head += ["property %s %s" % p for p in props] + ["end_header"]
    out = ("\n".join(head) + "\n").encode()
    if fmt_name == "ascii":
        out += "".join(" ".join("%.9g" % v for v in r) + "\n" for r in rows).encode()
    else:
        order = "<" if fmt_name == "binary_little_endian" else ">"
        fmt = order + "".join(SIZES[t] for t, _ in props)
        out += b"".join(struct.pack(fmt, *r) for r in rows)
    open(path, "wb").write(out)


def main():
    outdir = sys.argv[1]
    for k, frame in enumerate(sys.argv[2:]):
        props, comments, rows = parse(open(frame, "rb").read())
        for fmt_name, tag in (("binary_little_endian", "le"), ("binary_big_endian", "be"), ("ascii", "ascii")):
            write("%s/sandmpm_%d_%s.ply" % (outdir, k, tag), fmt_name, props, comments, rows[:3])
    cases = {
        "empty_vertex.ply": b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nend_header\n",
        "xy_only_ascii.ply": b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n0 1\n2 3\n",
        "double_int_ascii.ply": b"ply\nformat ascii 1.0\ncomment dim 3\nelement vertex 2\nproperty double x\n"
                                b"property double y\nproperty double z\nproperty int id\nproperty uchar material\n"
                                b"end_header\n0.5 0.25 1e-3 7 2\n-1 2 3 4294967295 255\n",
        "face_before_vertex.ply": b"ply\nformat binary_little_endian 1.0\nelement face 1\nproperty int a\n"
                                  b"element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
                                  + struct.pack("<i3f", 5, 1.0, 2.0, 3.0),
        "list_after_vertex.ply": b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                 b"element face 1\nproperty list uchar int vertex_indices\nend_header\n1 2\n3 0 0 0\n",
        "huge_count.ply": b"ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\n"
                          b"property float x\nproperty float y\nend_header\n\0\0\0\0",
        "truncated.ply": b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                         b"end_header\n\0\0\0\0\0\0",
        "crlf.ply": b"ply\r\nformat ascii 1.0\r\nelement vertex 1\r\nproperty float x\r\nproperty float y\r\nend_header\r\n1 2\r\n",
        "nan_inf_ascii.ply": b"ply\nformat ascii 1.0\ncomment domain 0 0 0 nan inf -inf\nelement vertex 2\n"
                             b"property float x\nproperty float y\nproperty float vx\nproperty float q\nend_header\n"
                             b"nan inf 1e40 -1e-50\n0x10 1e308 - +\n",
    }
    for name, data in cases.items():
        open("%s/%s" % (outdir, name), "wb").write(data)


main()
