"""World: one simulation (sm_world), its particles as NumPy views, stepping and diagnostics."""
import math

import numpy as np

from . import _fields
from ._ffi import ErrBuf, ffi, lib, real_dtype, world_error
from ._views import ViewTracker
from .collider import Collider, _Motion, attach
from .emitter import Emitter
from .material import Material
from .shapes import as_shape

_DEF_TYPE = ffi.typeof("sm_world_def")


def _world_defaults():
    return _fields.as_dict(ffi.new("sm_world_def *", lib.sm_world_def_default())[0])


class _Native:
    """Owns the sm_world pointer and what the library may call back into (motion handles); the
    world is destroyed exactly once, when the last reference goes (the World, or a particle array
    still alive after close())."""

    __slots__ = ("ptr", "keep")

    def __init__(self, ptr):
        self.ptr = ptr
        self.keep = []

    def destroy(self):
        if self.ptr is not None:
            ptr, self.ptr = self.ptr, None
            lib.sm_world_destroy(ptr)

    def __del__(self):
        try:
            self.destroy()
        except Exception:  # interpreter shutdown: the library may already be gone
            pass


class _Borrowed(_Native):
    """The pointer of a world that another object owns (a Scene's): never destroyed here; `keep`
    holds the owner's handle, so the owner's memory lives as long as this handle (the World or a
    particle array over it)."""

    __slots__ = ()

    def destroy(self):
        self.ptr = None
        self.keep = []


class World:
    """A simulation world. The keywords are the fields of sm_world_def with the same names and
    defaults (see help(World) or World.defaults()); enum fields take strings ("cubic", "flip",
    "implicit", "slip", ...), 3-vectors a sequence (2 numbers in 2D). A bad value raises
    sandmpm.Error with the library's message; an unknown keyword raises TypeError.

    Particle arrays (positions, velocities, B, F, q, alpha, material, volume) are NumPy views of the
    library's storage, without copies, valid until the next call that steps the world or adds
    particles (step, advance, run, seed, add_particles): after such a call every array handed out
    before, and every slice of it, is read-only — writing through it raises ValueError — and its
    contents are unspecified (the storage may have moved; a step also reorders the particles, so
    index i may then hold another particle). Take the attribute again after each step. np.asarray()
    of a view, or an array made from its buffer by other means, is not tracked. Only `velocities`
    is writable, and a write changes the next step.

    The world is freed by close() (or a with-block, or when it is garbage); arrays still alive then
    keep its memory until they go, read-only."""

    def __init__(self, **kw):
        d = ffi.new("sm_world_def *", lib.sm_world_def_default())
        _fields.fill(d[0], kw, "World()")
        out = ffi.new("sm_world **")
        err = ErrBuf()
        st = lib.sm_world_create(d, out, err.buf, err.SIZE)
        if st != lib.SM_OK:
            raise err.error(st)
        self._native = _Native(out[0])
        self._views = ViewTracker(self._native)
        self._materials = {}  # Material -> id in this world
        self._motions = []
        self.dim = d.dim

    @classmethod
    def _borrow(cls, ptr, owner):
        """A World over a world owned by `owner` (a native handle kept alive by this World and its
        arrays; the owner frees the world when the last of them goes)."""
        self = cls.__new__(cls)
        native = _Borrowed(ptr)
        native.keep.append(owner)
        self._native = native
        self._views = ViewTracker(native)
        self._materials = {}
        self._motions = []
        self.dim = lib.sm_world_get_def(ptr).dim
        return self

    @staticmethod
    def defaults():
        """sm_world_def_default() as a dict of keyword -> value."""
        return _world_defaults()

    # -- lifetime --------------------------------------------------------------------------

    @property
    def _w(self):
        native = self._native
        if native is None or native.ptr is None:
            raise ValueError("sandmpm.World: the world is closed")
        return native.ptr

    def close(self):
        """Frees the world (at once, unless particle arrays over it are still alive: then when the
        last of them goes). Further calls raise ValueError; calling close() again does nothing."""
        if self._native is not None:
            self._views.retire()
            self._views.owner = None
            self._native = None  # _Native.__del__ destroys the world once its last reference is gone

    @property
    def closed(self):
        return self._native is None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    # -- definition ------------------------------------------------------------------------

    @property
    def definition(self):
        """The definition the world was created with (domain rounded to whole cells), as a dict."""
        return _fields.as_dict(lib.sm_world_get_def(self._w)[0])

    @property
    def grid_size(self):
        n = ffi.new("int[3]")
        lib.sm_world_grid_size(self._w, n)
        return (n[0], n[1], n[2])

    def set_threads(self, threads):
        """Threads for later steps (0: OpenMP's default). Results do not depend on it."""
        lib.sm_world_set_threads(self._w, int(threads))

    def memory_bytes(self):
        """Heap bytes the world holds now (sm_world_memory_bytes)."""
        return lib.sm_world_memory_bytes(self._w)

    # -- contents --------------------------------------------------------------------------

    def _check(self, st):
        if st != lib.SM_OK:
            raise world_error(self._native.ptr, st)

    def add_material(self, material):
        """Adds a Material (once per world) and returns its id."""
        if not isinstance(material, Material):
            raise TypeError("add_material: expected a sandmpm.Material, got %r" % (material,))
        mid = self._materials.get(material)
        if mid is None:
            out = ffi.new("int *")
            self._check(lib.sm_world_add_material(self._w, material._c, out))
            mid = self._materials[material] = out[0]
        return mid

    def _material_id(self, material, what):
        if isinstance(material, Material):
            return self.add_material(material)
        if isinstance(material, int) and not isinstance(material, bool):
            return material
        raise TypeError("%s: material: expected a sandmpm.Material or a material id, got %r" % (what, material))

    def add_collider(self, collider):
        """Adds a Collider; returns its id. A motion callable is first called at the world's time
        (its errors raise here, before anything is added)."""
        if not isinstance(collider, Collider):
            raise TypeError("add_collider: expected a sandmpm.Collider, got %r" % (collider,))
        c = ffi.new("sm_collider_def *", collider._c[0])
        motion = None
        if collider.motion is not None:
            motion = _Motion(collider.motion, self.dim, "collider %d" % lib.sm_world_collider_count(self._w))
            motion.first_pose(self.time)
            attach(c, motion)
            self._native.keep.append(motion)
        out = ffi.new("int *")
        st = lib.sm_world_add_collider(self._w, c, out)
        if motion is not None:
            err = motion.take_error()
            if st == lib.SM_OK:
                self._motions.append(motion)
            if err is not None:
                raise err
        self._check(st)
        return out[0]

    def add_emitter(self, emitter):
        """Adds an Emitter (and its material); returns its id."""
        if not isinstance(emitter, Emitter):
            raise TypeError("add_emitter: expected a sandmpm.Emitter, got %r" % (emitter,))
        e = ffi.new("sm_emitter_def *", emitter._c[0])
        e.material = self.add_material(emitter.material)
        out = ffi.new("int *")
        self._check(lib.sm_world_add_emitter(self._w, e, out))
        return out[0]

    def emitted_mass(self, emitter_id):
        return lib.sm_world_emitted_mass(self._w, emitter_id)

    def seed(self, shape, material, clip=None, **kw):
        """Fills `shape` (clipped to the domain, and to `clip` if given) with particles of
        `material`; returns how many were added. Keywords are the fields of sm_seed_def with its
        defaults: ppc (8), method ("jittered" or "poisson"), seed (1), velocity, angular_velocity."""
        s = ffi.new("sm_seed_def *", lib.sm_seed_def_default())
        _fields.fill(s[0], kw, "World.seed()", skip=("material",))
        s.material = self._material_id(material, "seed")
        if clip is not None:
            s.clip = as_shape(clip, "seed: clip")._c
        added = ffi.new("size_t *")
        self._views.retire()
        try:
            self._check(lib.sm_world_seed_shape(self._w, as_shape(shape, "seed: shape")._c, s, added))
        finally:
            self._views.retire()
        return added[0]

    def add_particles(self, positions, material, velocities=None, ppc=8.0):
        """Adds particles at `positions` (n x d or n x 3), at rest or with `velocities` (same
        shape), undeformed, each of volume dx^d/ppc."""
        x = self._vectors(positions, "add_particles: positions")
        v = None if velocities is None else self._vectors(velocities, "add_particles: velocities")
        if v is not None and v.shape != x.shape:
            raise ValueError("add_particles: velocities: expected shape %s, got %s" % (x.shape, v.shape))
        mid = self._material_id(material, "add_particles")
        xp = ffi.from_buffer("double[]", x)
        vp = ffi.NULL if v is None else ffi.from_buffer("double[]", v)
        self._views.retire()
        try:
            self._check(lib.sm_world_add_particles(self._w, x.shape[0], xp, vp, mid, float(ppc)))
        finally:
            self._views.retire()

    def _vectors(self, a, what):
        a = np.asarray(a, dtype=np.float64)
        if a.ndim == 1 and a.size in (self.dim, 3):
            a = a.reshape(1, -1)
        if a.ndim != 2 or a.shape[1] not in (self.dim, 3):
            raise ValueError("%s: expected an array of shape (n, %d) or (n, 3), got %s" % (what, self.dim, a.shape))
        if a.shape[1] != 3:
            a = np.concatenate([a, np.zeros((a.shape[0], 3 - a.shape[1]))], axis=1)
        return np.ascontiguousarray(a)

    def collider_pose(self, collider_id):
        """The collider's current (position, rotation)."""
        p = ffi.new("sm_pose *")
        lib.sm_world_collider_pose(self._w, collider_id, p)
        return tuple(p.position), tuple(p.rotation)

    def collider_distance(self, collider_id, x):
        """Signed distance of the collider at point x now."""
        p = ffi.new("double[3]", _fields.vector(x, 3, "collider_distance: x"))
        return lib.sm_world_collider_distance(self._w, collider_id, p, ffi.NULL)

    # -- particles -------------------------------------------------------------------------

    def __len__(self):
        view = ffi.new("sm_particles_view *")
        lib.sm_world_particles(self._w, view)
        return view.n

    def _particles(self):
        view = self._views.cache.get("view")
        if view is None:
            view = ffi.new("sm_particles_view *")
            lib.sm_world_particles(self._w, view)
            self._views.cache["view"] = view
        return view

    def _array(self, name, cols, dtype=real_dtype):
        v = self._particles()
        shape = (v.n,) + cols
        return self._views.array(name, getattr(v, name), shape, dtype, writable=False)

    @property
    def positions(self):
        """Positions, (n, d), float64 in both builds (as the library stores them), read-only view
        (valid until the next step)."""
        return self._array("x", (self.dim,), np.dtype(np.float64))

    @property
    def velocities(self):
        """Velocities, (n, d), writable view (sm_world_particle_velocities: the library then checks
        every particle at the next step); valid until the next step."""
        cached = self._views.cache.get("v")
        if cached is not None:
            return cached
        n = len(self)
        return self._views.array("v", lib.sm_world_particle_velocities(self._w), (n, self.dim), real_dtype,
                                 writable=True)

    @property
    def B(self):
        """APIC affine matrices, (n, d, d), read-only view."""
        return self._array("B", (self.dim, self.dim))

    @property
    def F(self):
        """Elastic deformation gradients F^E, (n, d, d), read-only view."""
        return self._array("F", (self.dim, self.dim))

    @property
    def q(self):
        """Hardening state, (n,), read-only view."""
        return self._array("q", ())

    @property
    def alpha(self):
        """Drucker–Prager alpha, (n,), read-only view."""
        return self._array("alpha", ())

    @property
    def volume(self):
        """Initial particle volume V0 (vol0), (n,), read-only view."""
        return self._array("vol0", ())

    @property
    def material(self):
        """Material id per particle, (n,) uint16, read-only view."""
        return self._array("material", (), np.dtype(np.uint16))

    def masses(self):
        """Particle masses in kg (a new array: density of the material times V0)."""
        w = self._w
        return np.array([lib.sm_world_particle_mass(w, i) for i in range(len(self))])

    # -- time stepping ---------------------------------------------------------------------

    @property
    def time(self):
        """Simulated time, s."""
        return lib.sm_world_time(self._w)

    def next_dt(self, t_end=math.inf):
        """The step the world would take next, capped so it does not pass t_end."""
        return lib.sm_world_next_dt(self._w, float(t_end))

    def step(self, dt=None):
        """One step of dt seconds (None: the adaptive step, sm_world_next_dt). Invalidates the
        particle arrays. Raises sandmpm.Error if the library refuses or fails, and re-raises an
        exception that a motion callable raised during the step."""
        w = self._w
        if dt is None:
            dt = lib.sm_world_next_dt(w, math.inf)
        views = self._views
        if views.cache or views.arrays:
            views.retire()
        st = lib.sm_world_step(w, dt)
        if views.cache or views.arrays:
            views.retire()
        if self._motions:
            self._raise_motion_error()
        if st != lib.SM_OK:
            raise world_error(w, st)

    def _raise_motion_error(self):
        errors = [e for e in (m.take_error() for m in self._motions) if e is not None]
        if errors:
            raise errors[0]

    def advance(self, t_end, callback=None):
        """Adaptive steps until the world's time is exactly t_end (as sm_world_advance, with the
        same steps). callback(world), if given, runs after every step. With a motion callable the
        steps are taken one by one from Python, so its exception is raised after the step in which
        it happened."""
        t_end = float(t_end)
        w = self._w
        if callback is None and not self._motions:
            self._views.retire()
            try:
                self._check(lib.sm_world_advance(w, t_end))
            finally:
                self._views.retire()
            return
        if not math.isfinite(t_end):
            self._check(lib.sm_world_advance(w, t_end))  # the library's message
        retries = 0
        while lib.sm_world_time(w) < t_end:
            dt = lib.sm_world_next_dt(w, t_end)
            self._views.retire()
            if dt == t_end - lib.sm_world_time(w):
                st = lib.sm_world_advance(w, t_end)  # the last step: takes dt and lands on t_end exactly
            else:
                st = lib.sm_world_step(w, dt)
            self._views.retire()
            if self._motions:
                self._raise_motion_error()
            if st != lib.SM_OK and retries < 60 and lib.sm_world_step_refused(w):
                retries += 1  # refused (CFL check or implicit solve), world intact: retry at half the dt, as sm_world_advance
                continue
            retries = 0
            self._check(st)
            if callback is not None:
                callback(self)

    def run(self, frames, fps, on_frame=None, on_step=None):
        """A frame loop like the command line's: on_frame(world, 0) for the initial state, then for
        frame f = 1..frames: step statistics reset, advance to f / fps, on_frame(world, f).
        on_step(world) runs after every step."""
        if on_frame is not None:
            on_frame(self, 0)
        for f in range(1, int(frames) + 1):
            lib.sm_world_reset_step_stats(self._w)
            self.advance(f / fps, on_step)
            if on_frame is not None:
                on_frame(self, f)

    def reset_step_stats(self):
        lib.sm_world_reset_step_stats(self._w)

    # -- diagnostics -----------------------------------------------------------------------

    def diagnostics(self):
        """Every field of sm_diagnostics by name (vectors as 3-tuples); stage_seconds as a dict
        {stage name: seconds} (sm_stage_name)."""
        d = ffi.new("sm_diagnostics *")
        lib.sm_world_diagnostics(self._w, d)
        out = {}
        for name, field in ffi.typeof("sm_diagnostics").fields:
            value = getattr(d[0], name)
            if name == "stage_seconds":
                out[name] = {ffi.string(lib.sm_stage_name(i)).decode(): value[i] for i in range(lib.SM_STAGE_COUNT)}
            elif field.type.kind == "array":
                out[name] = tuple(value)
            else:
                out[name] = value
        return out

    def state_hash(self):
        """64-bit hash of all particle state, bitwise (sm_world_state_hash)."""
        return lib.sm_world_state_hash(self._w)

    def __repr__(self):
        if self.closed:
            return "<sandmpm.World (closed)>"
        return "<sandmpm.World dim=%d, %d particles, t=%.6g s>" % (self.dim, len(self), self.time)


World.__init__.__signature__ = _fields.signature(_world_defaults(), first=("self",))
