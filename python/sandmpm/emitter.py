"""Emitters (sm_emitter_def): particle sources with a mass flow rate."""
from . import _fields
from ._ffi import ffi, lib
from .material import Material
from .shapes import as_shape


class Emitter:
    """A particle source: emits `material` uniformly at random inside `shape` at `rate` kg/s
    (kg/(m s) in 2D) between `start` and `stop` seconds. Other keywords are the fields of
    sm_emitter_def with its defaults: ppc (8: V0 = dx^d/ppc), velocity, start (0), stop (inf),
    seed (1). The material is added to a world the first time the emitter is."""

    __slots__ = ("_c", "_shape", "_material")

    def __init__(self, shape, material, rate, **kw):
        if not isinstance(material, Material):
            raise TypeError("Emitter: material: expected a sandmpm.Material, got %r" % (material,))
        c = ffi.new("sm_emitter_def *", lib.sm_emitter_def_default())
        c.shape = as_shape(shape, "Emitter: shape")._c[0]
        kw["rate"] = rate
        _fields.fill(c[0], kw, "Emitter()", skip=("material",))
        object.__setattr__(self, "_c", c)
        object.__setattr__(self, "_shape", shape)
        object.__setattr__(self, "_material", material)

    def __setattr__(self, name, value):
        raise AttributeError("Emitter is immutable")

    @property
    def shape(self):
        return self._shape

    @property
    def material(self):
        return self._material

    def fields(self):
        return _fields.as_dict(self._c[0], skip=("material",))

    def __repr__(self):
        return "Emitter(%r, %r, %s)" % (self._shape, self._material,
                                        ", ".join("%s=%r" % kv for kv in self.fields().items()))
