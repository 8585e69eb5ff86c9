"""Shapes: the library's signed-distance primitives (sm_shape), negative inside."""
import math

from . import _fields
from ._ffi import ffi, lib


def axis_angle(axis, degrees):
    """The unit quaternion (w, x, y, z) of a rotation by `degrees` about `axis` (as the scenes'
    axis_angle)."""
    ax = _fields.vector(axis, 3, "axis_angle: axis")
    n = math.sqrt(sum(a * a for a in ax))
    if not n > 0:
        raise ValueError("axis_angle: the axis must not be zero")
    h = math.radians(_fields.real(degrees, "axis_angle: degrees")) / 2
    s = math.sin(h) / n
    return (math.cos(h), ax[0] * s, ax[1] * s, ax[2] * s)


class Shape:
    """One primitive shape. Make one with Shape.box, sphere, cylinder or halfspace; the keywords are
    the fields of sm_shape (center, half_extent, radius, half_height, normal, rotation as a unit
    quaternion (w, x, y, z), inside_out). Shapes are values: immutable, shareable between worlds."""

    __slots__ = ("_c",)

    def __init__(self, kind, /, **kw):
        kind_value = _fields.enum_value(ffi.typeof("sm_shape_kind"), kind, "Shape: kind")
        c = ffi.new("sm_shape *", lib.sm_shape_default(kind_value))
        _fields.fill(c[0], kw, "Shape.%s()" % _fields.enum_name(ffi.typeof("sm_shape_kind"), kind_value),
                     skip=("kind",))
        object.__setattr__(self, "_c", c)

    @classmethod
    def box(cls, center, half_extent, rotation=(1, 0, 0, 0), inside_out=False):
        """A box of half sizes `half_extent` about `center`, turned by `rotation`."""
        return cls("box", center=center, half_extent=half_extent, rotation=rotation, inside_out=inside_out)

    @classmethod
    def sphere(cls, center, radius, inside_out=False):
        """A ball (a disk in 2D)."""
        return cls("sphere", center=center, radius=radius, inside_out=inside_out)

    @classmethod
    def cylinder(cls, center, radius, half_height, rotation=(1, 0, 0, 0), inside_out=False):
        """A capped cylinder whose axis is the local y axis, turned by `rotation`."""
        return cls("cylinder", center=center, radius=radius, half_height=half_height, rotation=rotation,
                   inside_out=inside_out)

    @classmethod
    def halfspace(cls, point, normal, inside_out=False):
        """Solid below the plane through `point` with outward `normal`."""
        return cls("halfspace", center=point, normal=normal, inside_out=inside_out)

    def __setattr__(self, name, value):
        raise AttributeError("Shape is immutable; use shape.replace(%s=...)" % name)

    def __getattr__(self, name):
        c = object.__getattribute__(self, "_c")
        fields = _fields.settable_fields(ffi.typeof("sm_shape"))
        if name not in fields:
            raise AttributeError("Shape has no field %r%s" % (name, _fields.did_you_mean(name, fields)))
        return _fields.to_python(getattr(c[0], name), fields[name])

    @property
    def kind(self):
        return _fields.enum_name(ffi.typeof("sm_shape_kind"), self._c.kind)

    def fields(self):
        """The sm_shape fields as a dict."""
        return _fields.as_dict(self._c[0])

    def replace(self, **kw):
        """A copy with some fields changed."""
        f = self.fields()
        f.update(kw)
        kind = f.pop("kind")
        return Shape(kind, **f)

    def distance(self, x, dim=3, gradient=False):
        """Signed distance at point x (negative inside); with gradient=True, (distance, unit gradient)."""
        p = ffi.new("double[3]", _fields.vector(x, 3, "Shape.distance: x"))
        g = ffi.new("double[3]") if gradient else ffi.NULL
        d = lib.sm_shape_distance(self._c, dim, p, g)
        return (d, (g[0], g[1], g[2])) if gradient else d

    def volume_estimate(self, lo, hi, dim=3, clip=None):
        """Volume of shape ∩ clip ∩ [lo, hi] estimated on a 64^dim lattice (sm_shape_volume_estimate)."""
        a = ffi.new("double[3]", _fields.vector(lo, 3, "Shape.volume_estimate: lo"))
        b = ffi.new("double[3]", _fields.vector(hi, 3, "Shape.volume_estimate: hi"))
        return lib.sm_shape_volume_estimate(self._c, clip._c if clip is not None else ffi.NULL, dim, a, b)

    def __repr__(self):
        f = self.fields()
        kind = f.pop("kind")
        keep = {"box": ("center", "half_extent", "rotation"), "sphere": ("center", "radius"),
                "cylinder": ("center", "radius", "half_height", "rotation"), "halfspace": ("center", "normal")}
        parts = ["%s=%r" % (k, f[k]) for k in keep.get(kind, f)]
        if f["inside_out"]:
            parts.append("inside_out=True")
        return "Shape.%s(%s)" % (kind, ", ".join(parts))


def as_shape(value, what):
    if not isinstance(value, Shape):
        raise TypeError("%s: expected a sandmpm.Shape, got %r" % (what, value))
    return value
