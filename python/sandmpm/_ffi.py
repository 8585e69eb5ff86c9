"""The library, loaded with cffi in ABI mode, and the error type.

The declarations are _cdef.h, which the build makes from include/sandmpm/sandmpm.h (python/cdef.cmake),
so they are the header's own, and _cdef_app.h from the application layer's headers (app/). The
library is found, in this order, at $SANDMPM_LIBRARY, at the path _paths.py names (the build tree's
libsandmpm.so, or the installed one relative to this package), and by the system's library search
(libsandmpm.so.0); the application layer's (_app.py) the same way, at $SANDMPM_APP_LIBRARY or
libsandmpm_app.so.0.
"""
import enum
import os

import cffi
import numpy as np

_here = os.path.dirname(os.path.abspath(__file__))

ffi = cffi.FFI()
with open(os.path.join(_here, "_cdef.h")) as _f:
    ffi.cdef(_f.read())
# The application layer's declarations (frames, renderer, scene loader, a scene's run), whose
# library (libsandmpm_app.so) is loaded on first use (_app.py).
with open(os.path.join(_here, "_cdef_app.h")) as _f:
    ffi.cdef(_f.read())


def _library_path(env_name="SANDMPM_LIBRARY", attr="LIBRARY", soname="libsandmpm.so.0"):
    env = os.environ.get(env_name)
    if env:
        return env
    try:
        from . import _paths
    except ImportError:
        return soname
    where = getattr(_paths, attr, None)
    if where is None:
        return soname
    path = os.path.join(_here, where) if _paths.RELATIVE else where
    return os.path.normpath(path)


library_path = _library_path()
lib = ffi.dlopen(library_path)

# The declarations and the library must agree on the precision (one build's header and another's
# library would make every particle array wrong).
if ffi.sizeof("sm_real") != (8 if lib.sm_real_is_double() else 4):
    raise ImportError(
        "sandmpm: %s was built with sm_real = %s but the package's declarations (_cdef.h) say %s; "
        "use the package from the same build as the library"
        % (library_path, "double" if lib.sm_real_is_double() else "float", ffi.getctype("sm_real")))

real_dtype = np.dtype(np.float64 if lib.sm_real_is_double() else np.float32)


def _status_enum():
    elements = ffi.typeof("sm_status").elements  # {value: "SM_ERR_INVALID", ...}
    return enum.IntEnum("Status", {name[3:]: value for value, name in sorted(elements.items())})


#: The library's status codes as an IntEnum: Status.OK, Status.ERR_INVALID, Status.ERR_NUMERICAL, ...
Status = _status_enum()


class Error(Exception):
    """A library call failed. ``status`` is the sm_status (a Status), ``message`` the library's message
    (sm_world_errmsg or the error buffer of the call)."""

    def __init__(self, status, message):
        self.status = Status(status)
        self.message = message
        super().__init__(message or status_string(status))

    def __str__(self):
        return "%s (%s)" % (self.message, status_string(self.status)) if self.message else status_string(self.status)


def status_string(status):
    """The library's short name of a status ("ok", "invalid input", ...)."""
    return ffi.string(lib.sm_status_string(int(status))).decode()


def world_error(w, status):
    """The Error for a failed call on world pointer ``w``."""
    return Error(status, ffi.string(lib.sm_world_errmsg(w)).decode(errors="replace"))


class ErrBuf:
    """A char buffer for the calls that report into (err, errlen)."""

    SIZE = 512

    def __init__(self):
        self.buf = ffi.new("char[]", self.SIZE)

    def error(self, status):
        return Error(status, ffi.string(self.buf).decode(errors="replace"))
