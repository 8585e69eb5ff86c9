"""Keyword arguments <-> the library's definition structs, read generically from the cffi types.

Every keyword is a field of the C struct with the same name; defaults come from the library's
sm_*_default() functions. Enum fields take the lower-case tail of the C names ("cubic" for
SM_KERNEL_CUBIC, "sticky" for SM_COLLIDE_STICKY) or the integer. Array fields take a sequence of
that length; 3-vectors also take 2 numbers (z = 0, as the library ignores z in 2D).
"""
import difflib
import inspect

from ._ffi import ffi


def did_you_mean(word, choices):
    close = difflib.get_close_matches(word, list(choices), n=1)
    return " (did you mean %r?)" % close[0] if close else ""


def unknown_keyword(owner, key, choices):
    return TypeError("%s got an unexpected keyword argument %r%s" % (owner, key, did_you_mean(key, choices)))


def enum_names(ctype):
    """{"quadratic": 0, "cubic": 1} for an enum type: the element names minus their common prefix,
    lower case (the *_COUNT sentinel of sm_stage-like enums is left out)."""
    names = {value: name for value, name in ctype.elements.items() if not name.endswith("_COUNT")}
    prefix = _common_prefix(list(names.values()))
    return {name[len(prefix):].lower(): value for value, name in names.items()}


def _common_prefix(names):
    if len(names) == 1:
        return names[0][: names[0].rfind("_") + 1]
    p = names[0]
    for n in names[1:]:
        while not n.startswith(p):
            p = p[:-1]
    return p[: p.rfind("_") + 1]


def enum_value(ctype, value, what):
    names = enum_names(ctype)
    if isinstance(value, str):
        key = value.lower()
        if key not in names:
            raise ValueError("%s: unknown value %r; one of %s%s"
                             % (what, value, ", ".join(repr(n) for n in names), did_you_mean(key, names)))
        return names[key]
    if isinstance(value, bool) or not isinstance(value, int) or value not in names.values():
        raise ValueError("%s: expected one of %s, got %r" % (what, ", ".join(repr(n) for n in names), value))
    return value


def enum_name(ctype, value):
    for name, v in enum_names(ctype).items():
        if v == value:
            return name
    return int(value)


def set_field(cdata, name, ftype, value, what):
    """Sets one field of a struct (primitive, enum or array of primitives)."""
    if ftype.kind == "enum":
        setattr(cdata, name, enum_value(ftype, value, what))
    elif ftype.kind == "array":
        setattr(cdata, name, vector(value, ftype.length, what))
    elif ftype.kind == "primitive":
        if ftype.cname in ("float", "double"):
            setattr(cdata, name, real(value, what))
        else:
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            if not isinstance(value, int):
                raise TypeError("%s: expected an integer, got %r" % (what, value))
            try:
                setattr(cdata, name, value)
            except OverflowError:
                raise ValueError("%s: %r is out of range for %s" % (what, value, ftype.cname)) from None
    else:
        raise TypeError("%s: a %s field cannot be set from Python" % (what, ftype.kind))


def real(value, what):
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError("%s: expected a number, got %r" % (what, value)) from None


def vector(value, length, what):
    """A list of `length` floats from a sequence (a 3-vector also from 2 numbers, z = 0)."""
    try:
        items = [real(x, what) for x in value]
    except TypeError:
        if isinstance(value, (int, float)):
            raise TypeError("%s: expected %d numbers, got %r" % (what, length, value)) from None
        raise
    if length == 3 and len(items) == 2:
        items.append(0.0)
    if len(items) != length:
        raise ValueError("%s: expected %d numbers, got %d" % (what, length, len(items)))
    return items


def fill(cdata, kw, owner, skip=()):
    """Sets the struct fields named by the keywords of kw; unknown names raise TypeError."""
    fields = settable_fields(ffi.typeof(cdata))
    for key, value in kw.items():
        if key not in fields or key in skip:
            raise unknown_keyword(owner, key, [f for f in fields if f not in skip])
        set_field(cdata, key, fields[key], value, "%s: %s" % (owner, key))
    return cdata


def settable_fields(ctype):
    """{name: field ctype} of the fields that set_field can set."""
    out = {}
    for name, field in ctype.fields:
        t = field.type
        if t.kind in ("primitive", "enum") or (t.kind == "array" and t.item.kind == "primitive"):
            out[name] = t
    return out


def to_python(cdata, ftype):
    """A field's value as Python: number, enum name, tuple for arrays."""
    if ftype.kind == "enum":
        return enum_name(ftype, int(ffi.cast("int", cdata)) if not isinstance(cdata, int) else cdata)
    if ftype.kind == "array":
        return tuple(cdata[i] for i in range(ftype.length))
    return cdata


def as_dict(cdata, skip=()):
    """The settable fields of a struct as {name: value}."""
    out = {}
    for name, t in settable_fields(ffi.typeof(cdata)).items():
        if name not in skip:
            out[name] = to_python(getattr(cdata, name), t)
    return out


def signature(defaults, first=()):
    """An inspect.Signature of keyword-only parameters with these defaults (for help())."""
    params = [inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD) for n in first]
    params += [inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY, default=v) for k, v in defaults.items()]
    return inspect.Signature(params)
