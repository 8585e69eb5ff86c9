"""sandmpm from Python: dry sand with the Material Point Method (Klár 2016), over libsandmpm.

    import sandmpm as sm
    with sm.World(dx=0.025) as w:
        sand = sm.Material.sand()
        w.add_collider(sm.Collider(sm.Shape.halfspace((0, 0.1, 0), (0, 1, 0))))
        w.seed(sm.Shape.cylinder((0.5, 0.25, 0.5), 0.08, 0.15), sand, ppc=8)
        w.run(12, 24, on_frame=lambda w, f: print(f, w.diagnostics()["center_of_mass"]))

The classes are thin: their keywords are the fields of the C definitions (sandmpm.h) with the same
names and defaults. Particle state (World.positions, velocities, B, F, q, alpha, material, volume)
is NumPy views of the library's memory, valid until the next step. Lua scene files: load_scene(path,
quality=..., **params) and Scene.run(out), the outputs of `sandmpm run`; render() draws a frame or
a world into a NumPy image. See docs/python.md.
"""
from ._ffi import Error, Status, ffi, lib, library_path, real_dtype, status_string
from ._views import ParticleArray
from .collider import Collider
from .emitter import Emitter
from .frame import Frame, frame_from_world, read_frame, render, write_ply, write_png
from .material import Material
from .scene import Scene, load_scene
from .shapes import Shape, axis_angle
from .world import World

__version__ = ffi.string(lib.sm_version()).decode()

#: True if the library's sm_real is double (else float)
real_is_double = bool(lib.sm_real_is_double())


def allocation_count():
    """Heap allocations the library has made in this process, all worlds together (a counter that
    only grows; sm_allocation_count)."""
    return lib.sm_allocation_count()


def particle_bytes(dim):
    """Bytes per particle held by the library (sm_particle_bytes)."""
    return lib.sm_particle_bytes(dim)


def stage_names():
    """The step's stages in order ("dt", "sort", "p2g", ...)."""
    return [ffi.string(lib.sm_stage_name(i)).decode() for i in range(lib.SM_STAGE_COUNT)]


__all__ = ["World", "Material", "Shape", "Collider", "Emitter", "Error", "Status", "ParticleArray", "axis_angle",
           "Scene", "load_scene", "Frame", "read_frame", "frame_from_world", "write_ply", "render", "write_png",
           "allocation_count", "particle_bytes", "stage_names", "status_string", "real_dtype", "real_is_double",
           "library_path", "__version__"]
