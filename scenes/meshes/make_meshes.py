#!/usr/bin/python3
"""Writes the small tool meshes of scenes/meshes/ (issue 15) as OBJ files, in metres:

  shovel.obj  a curved blade (2 cm plate bent along its width) with a shaft
  rake.obj    a bar with ten tines (separate overlapping closed parts: their union is taken by
              winding number)
  bowl.obj    a thick hemispherical shell with a flat foot (a container to pour sand into)
  plough.obj  a wedge share with a curved mouldboard

Every part is a closed, manifold, outward-oriented triangle mesh. Run: /usr/bin/python3
scenes/meshes/make_meshes.py (standard library only); the files are rewritten in place.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


class Mesh:
    def __init__(self):
        self.v = []
        self.f = []

    def add(self, other):
        base = len(self.v)
        self.v += other.v
        self.f += [(a + base, b + base, c + base) for a, b, c in other.f]

    def volume(self):
        s = 0.0
        for a, b, c in self.f:
            (ax, ay, az), (bx, by, bz), (cx, cy, cz) = self.v[a], self.v[b], self.v[c]
            s += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
        return s / 6.0

    def outward(self):
        if self.volume() < 0:
            self.f = [(a, c, b) for a, b, c in self.f]
        return self

    def write(self, name, comment):
        path = os.path.join(HERE, name)
        with open(path, "w") as out:
            out.write("# %s\n# written by scenes/meshes/make_meshes.py; metres\n" % comment)
            for x, y, z in self.v:
                out.write("v %.6g %.6g %.6g\n" % (x, y, z))
            for a, b, c in self.f:
                out.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))
        print("%s: %d vertices, %d triangles, volume %.6g m^3" % (name, len(self.v), len(self.f), self.volume()))


def prism(outline, z0, z1, caps=None):
    """The simple polygon `outline` (x, y) extruded over z in [z0, z1]. caps: a triangulation of
    the outline (index triples in the outline's own orientation); by default a fan from the
    centroid, so the outline must then be star-shaped from it."""
    m = Mesh()
    n = len(outline)
    for z in (z0, z1):
        m.v += [(x, y, z) for x, y in outline]
    if caps is None:
        cx = sum(p[0] for p in outline) / n
        cy = sum(p[1] for p in outline) / n
        m.v += [(cx, cy, z0), (cx, cy, z1)]
        caps = [(2 * n, i, (i + 1) % n) for i in range(n)]  # centroid index 2n stands for either cap
    for a, b, c in caps:
        lift = lambda i: 2 * n + 1 if i == 2 * n else i + n
        m.f += [(a, c, b), (lift(a), lift(b), lift(c))]
    for i in range(n):
        j = (i + 1) % n
        m.f += [(i, j, n + j), (i, n + j, n + i)]
    return m.outward()


def thick_curve(curve, thickness, z0, z1):
    """A plate: the polyline `curve` [(x, y)] offset by `thickness` to its left, extruded over z;
    one closed mesh (caps are the strip between the two sides)."""
    left = []
    for i, (x, y) in enumerate(curve):
        a, b = curve[max(i - 1, 0)], curve[min(i + 1, len(curve) - 1)]
        dx, dy = b[0] - a[0], b[1] - a[1]
        L = math.hypot(dx, dy)
        left.append((x - thickness * dy / L, y + thickness * dx / L))
    n = len(curve)
    outline = list(curve) + left[::-1]
    inner = lambda i: 2 * n - 1 - i
    caps = []
    for i in range(n - 1):
        caps += [(i, i + 1, inner(i + 1)), (i, inner(i + 1), inner(i))]
    return prism(outline, z0, z1, caps)


def box(cx, cy, cz, hx, hy, hz):
    outline = [(cx - hx, cy - hy), (cx + hx, cy - hy), (cx + hx, cy + hy), (cx - hx, cy + hy)]
    return prism(outline, cz - hz, cz + hz)


def transform(m, f):
    m.v = [f(*p) for p in m.v]
    return m.outward()


def revolve(profile, n):
    """Surface of revolution about z of a closed profile [(r, z)], r >= 0; points with r = 0 are
    single vertices on the axis."""
    m = Mesh()
    ids = []
    for r, z in profile:
        if r == 0.0:
            ids.append([len(m.v)] * n)
            m.v.append((0.0, 0.0, z))
        else:
            ids.append(list(range(len(m.v), len(m.v) + n)))
            m.v += [(r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n), z) for k in range(n)]
    for i in range(len(profile)):
        a, b = ids[i], ids[(i + 1) % len(profile)]
        for k in range(n):
            k1 = (k + 1) % n
            for tri in ((a[k], b[k], b[k1]), (a[k], b[k1], a[k1])):
                if len(set(tri)) == 3:
                    m.f.append(tri)
    return m.outward()


def shovel():
    # Blade: an arc of radius 0.3 m through 50 degrees (about 0.26 m wide), 2 cm thick (1.5 cells at
    # the preview dx: a thinner plate lets the grid leak), 0.3 m long
    # (along z); the shaft (a 32 mm octagonal bar, 1 m) rises from the blade's back, overlapping it.
    R, half = 0.3, math.radians(25)
    arc = [(R * math.sin(a), R - R * math.cos(a)) for a in [-half + 2 * half * k / 16 for k in range(17)]]
    m = Mesh()
    m.add(thick_curve(arc, 0.02, 0.0, 0.3))
    octo = [(0.016 * math.cos(math.pi / 8 + k * math.pi / 4), 0.016 * math.sin(math.pi / 8 + k * math.pi / 4)) for k in range(8)]
    m.add(transform(prism(octo, 0.0, 1.0), lambda x, y, z: (x, y - 0.01, 0.2 + z)))
    return m


def rake():
    m = Mesh()
    m.add(box(0.0, 0.0, 0.0, 0.25, 0.015, 0.015))            # the bar, 0.5 m
    for k in range(10):                                          # tines, 8 cm long, pointing -y
        x = -0.225 + 0.05 * k
        m.add(box(x, -0.05, 0.0, 0.004, 0.045, 0.004))
    m.add(box(0.0, 0.0, 0.5, 0.012, 0.012, 0.5))                # the handle, along z
    return m


def bowl():
    # Outer radius 0.2 m, wall 3 cm (3 cells at dx = 1 cm: a wall thinner than about 2 dx lets the
    # grid leak), rim at z = 0, a flat foot of radius 6 cm 1 cm below the
    # outer sphere. The profile (r, z) runs: foot, outer arc up to the rim, inner arc down to the
    # axis (angle phi from the bottom: r = rho sin phi, z = -rho cos phi).
    Ro, t, rf, n = 0.2, 0.03, 0.06, 48
    foot = -Ro - 0.01
    p0 = math.asin(rf / Ro)
    prof = [(0.0, foot), (rf, foot)]
    prof += [(Ro * math.sin(p), -Ro * math.cos(p)) for p in [p0 + (math.pi / 2 - p0) * k / 12 for k in range(13)]]
    prof += [((Ro - t) * math.sin(p), -(Ro - t) * math.cos(p)) for p in [math.pi / 2 * (12 - k) / 12 for k in range(12)]]
    prof.append((0.0, -(Ro - t)))
    return revolve(prof, n)


def plough():
    m = Mesh()
    m.add(prism([(0.0, 0.0), (0.35, -0.08), (0.35, 0.08)], 0.0, 0.12))   # a wedge share pointing -x
    # The mouldboard: a 12 mm plate curving sideways behind the share (and overlapping it), 0.25 m high.
    board = [(0.15 + 0.35 * a, 0.03 + 0.2 * a * a) for a in [k / 12.0 for k in range(13)]]
    m.add(thick_curve(board, 0.012, 0.0, 0.25))
    return m


if __name__ == "__main__":
    shovel().write("shovel.obj", "shovel: curved 2 cm blade 0.26 x 0.3 m, 1 m shaft")
    rake().write("rake.obj", "rake: 0.5 m bar, ten 8 cm tines, 1 m handle")
    bowl().write("bowl.obj", "bowl: outer radius 0.2 m, 3 cm wall, rim at z = 0")
    plough().write("plough.obj", "plough: wedge share and curved mouldboard, 0.5 m long")
