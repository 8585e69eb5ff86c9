"""Materials (sm_material_def): sand (Drucker–Prager, thesis §3.3) and an elastic solid."""
from . import _fields
from ._ffi import ErrBuf, ffi, lib


class Material:
    """A material definition. Make one with Material.sand(**kw) or Material.elastic(**kw); the
    keywords are the fields of sm_material_def (density, youngs_modulus, poisson_ratio, hardening,
    friction_angle, h0..h3; angles in degrees), with the library's defaults. The definition is
    checked at once (sm_material_def_check): a bad value raises sandmpm.Error with the library's
    message. Materials are values: immutable, usable in several worlds (each world adds a material
    once, the first time it is used, and keeps its id)."""

    __slots__ = ("_c",)

    def __init__(self, kind, /, **kw):
        kind_value = _fields.enum_value(ffi.typeof("sm_material_kind"), kind, "Material: kind")
        base = lib.sm_material_def_sand() if kind_value == lib.SM_MATERIAL_SAND else lib.sm_material_def_elastic()
        c = ffi.new("sm_material_def *", base)
        _fields.fill(c[0], kw, "Material.%s()" % _fields.enum_name(ffi.typeof("sm_material_kind"), kind_value),
                     skip=("kind",))
        err = ErrBuf()
        st = lib.sm_material_def_check(c, err.buf, err.SIZE)
        if st != lib.SM_OK:
            raise err.error(st)
        object.__setattr__(self, "_c", c)

    @classmethod
    def sand(cls, **kw):
        """Sand: defaults rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.2/10 (sm_material_def_sand).
        hardening=False with friction_angle=phi gives a fixed friction angle."""
        return cls("sand", **kw)

    @classmethod
    def elastic(cls, **kw):
        """An elastic solid: defaults rho 1000, E 1e5, nu 0.3 (sm_material_def_elastic)."""
        return cls("elastic", **kw)

    def __setattr__(self, name, value):
        raise AttributeError("Material is immutable; use material.replace(%s=...)" % name)

    def __getattr__(self, name):
        c = object.__getattribute__(self, "_c")
        fields = _fields.settable_fields(ffi.typeof("sm_material_def"))
        if name not in fields:
            raise AttributeError("Material has no field %r%s" % (name, _fields.did_you_mean(name, fields)))
        return _fields.to_python(getattr(c[0], name), fields[name])

    def fields(self):
        """The sm_material_def fields as a dict."""
        return _fields.as_dict(self._c[0])

    def replace(self, **kw):
        f = self.fields()
        f.update(kw)
        return Material(f.pop("kind"), **f)

    def friction_angle_at(self, q):
        """Friction angle in degrees at hardening state q (thesis 3.79)."""
        return lib.sm_hardening_friction_angle(self._c, q)

    def __repr__(self):
        f = self.fields()
        return "Material.%s(%s)" % (f.pop("kind"), ", ".join("%s=%r" % kv for kv in f.items()))
