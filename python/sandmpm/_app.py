"""The application layer's library (libsandmpm_app.so: scene files, frames, the renderer, a scene's
run), loaded on first use over the same libsandmpm.so as the core (its declarations are
_cdef_app.h, read by _ffi.py)."""
from ._ffi import _library_path, ffi, lib

_app = None


def app_library_path():
    return _library_path("SANDMPM_APP_LIBRARY", "APP_LIBRARY", "libsandmpm_app.so.0")


def app():
    """The loaded application library (cffi lib object)."""
    global _app
    if _app is None:
        lib.sm_version()  # the core first, so the application library binds to the same libsandmpm.so
        _app = ffi.dlopen(app_library_path())
    return _app
