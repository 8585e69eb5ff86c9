"""Reading sandmpm's output and measuring deposits (docs/validation.md, "Measuring a deposit").

read_ply(path)           -> dict of numpy arrays (x, y, z, vx, vy, vz, material, q, friction_angle, Je, volume)
                            and 'dim' (from the header's "comment dim").
thickness_profile(...)   -> bin centres and the deposit thickness h in each bin: the particles'
                            current volume (V0 Je) per unit base length (2D: bins in x of width b)
                            or per unit base area (3D quarter column: annuli in r = sqrt(x^2 + z^2)
                            of width b over a quarter of the plane).
measure(...)             -> front (runout L or R), height H, the farthest particle, and the
                            largest bin thickness.

Definitions (written down in docs/validation.md):
  s      = the particle spacing dx / ppc^(1/d); h_min = 0.75 s, one particle layer less a quarter
           (a layer slightly compacted, Je < 1, is a little thinner than s: with h_min = s the
           front at a = 8 in 2D jumped by 1.2 L0 between the float and the double build, which
           differ in rounding only; bins of width dx = 2 s in 2D hold whole half layers, so 0.75 s
           lies between the levels);
  front  = going outward from the wall/axis in bins of width dx, the last bin whose thickness is
           >= h_min (gaps of at most one thinner bin are bridged; isolated particles and a
           thinner scatter beyond do not count); the front is the farthest particle in that bin
           plus s/2 (a particle stands for a cell of size s);
  height = the highest particle inside the front, plus s/2.
At t = 0 these give L0 (or R0) and H0 to within the seeding jitter.
"""
import math
import re

import numpy as np

_TYPES = {"float": "<f4", "ushort": "<u2", "double": "<f8", "int": "<i4", "uint": "<u4", "uchar": "u1"}


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii")
    n = int(re.search(r"element vertex (\d+)", header).group(1))
    dim = int(re.search(r"comment dim (\d)", header).group(1))
    fields = [(name, _TYPES[t]) for t, name in re.findall(r"property (\w+) (\w+)", header)]
    arr = np.frombuffer(data, dtype=np.dtype(fields), count=n, offset=end)
    out = {name: arr[name].astype(np.float64) for name, _ in fields}
    out["dim"] = dim
    out["n"] = n
    return out


def thickness_profile(p, dx, axisymmetric=False):
    """Bins of width dx from the wall (2D: x = 0) or the axis (3D quarter: r = 0)."""
    vol = p["volume"] * p["Je"]
    if axisymmetric:
        r = np.hypot(p["x"], p["z"])
    else:
        r = p["x"]
    r = np.maximum(r, 0.0)
    nb = int(np.ceil(r.max() / dx)) + 2 if len(r) else 2
    idx = np.minimum((r / dx).astype(int), nb - 1)
    v = np.bincount(idx, weights=vol, minlength=nb)
    edges = np.arange(nb + 1) * dx
    if axisymmetric:
        area = 0.25 * math.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
    else:
        area = np.full(nb, dx)
    return 0.5 * (edges[1:] + edges[:-1]), v / area


def measure(p, dx, ppc, axisymmetric=False):
    """Returns dict(front, height, farthest) in metres."""
    d = p["dim"]
    centres, h = thickness_profile(p, dx, axisymmetric)
    s = dx / ppc ** (1.0 / d)
    hmin = 0.75 * s  # one layer less a quarter: a layer at Je < 1 is thinner than s (above)
    front_bin = -1
    gap = 0
    for i, hi in enumerate(h):
        if hi >= hmin:
            front_bin = i
            gap = 0
        else:
            gap += 1
            if gap > 1 and front_bin >= 0:
                break
    r = np.hypot(p["x"], p["z"]) if axisymmetric else p["x"]
    in_front_bin = (r >= front_bin * dx) & (r < (front_bin + 1) * dx)
    front = float(r[in_front_bin].max()) + 0.5 * s
    inside = r <= front
    return {
        "front": front,
        "height": float(p["y"][inside].max()) + 0.5 * s,
        "farthest": float(r.max()) + 0.5 * s,
        "hmax_volume": float(h.max()),
    }


def read_csv(path):
    """diagnostics.csv as a dict of numpy columns (docs/outputs.md); an empty field (dt_min_s and
    dt_max_s of a frame without steps, frame 0) is NaN."""
    with open(path) as f:
        names = f.readline().strip().split(",")
        rows = [[float(v) if v.strip() else math.nan for v in line.split(",")] for line in f if line.strip()]
    a = np.array(rows)
    return {n: a[:, i] for i, n in enumerate(names)}


def fit_power(a, y):
    """Least-squares y = k a^e in log-log; returns (k, e)."""
    la, ly = np.log(np.asarray(a, float)), np.log(np.asarray(y, float))
    e, lk = np.polyfit(la, ly, 1)
    return float(math.exp(lk)), float(e)


def surface_profile(p, dx, ppc, axisymmetric=False):
    """Top surface per bin of width dx: the highest particle plus s/2 (NaN where a bin is empty)."""
    d = p["dim"]
    s = dx / ppc ** (1.0 / d)
    r = np.hypot(p["x"], p["z"]) if axisymmetric else p["x"]
    r = np.maximum(r, 0.0)
    nb = int(np.ceil(r.max() / dx)) + 1
    idx = np.minimum((r / dx).astype(int), nb - 1)
    top = np.full(nb, -np.inf)
    np.maximum.at(top, idx, p["y"])
    top = np.where(np.isfinite(top), top + 0.5 * s, np.nan)
    return (np.arange(nb) + 0.5) * dx, top


def flank_angle(p, dx, ppc, axisymmetric=False, lo=0.2, hi=0.8):
    """Angle of repose of a pile: a least-squares line through the top surface where it lies
    between lo and hi of the peak height, outward of the peak (degrees); with the peak height and
    the front (measure())."""
    r, top = surface_profile(p, dx, ppc, axisymmetric)
    m = measure(p, dx, ppc, axisymmetric)
    ok = np.isfinite(top) & (r <= m["front"])
    H = np.nanmax(top[ok])
    ipk = int(np.nanargmax(np.where(ok, top, -np.inf)))
    sel = ok & (np.arange(len(r)) >= ipk) & (top >= lo * H) & (top <= hi * H)
    if sel.sum() < 3:
        return {"angle": float("nan"), "peak": float(H), "front": m["front"], "points": int(sel.sum())}
    slope, _ = np.polyfit(r[sel], top[sel], 1)
    return {"angle": float(math.degrees(math.atan(-slope))), "peak": float(H), "front": m["front"],
            "points": int(sel.sum())}
