"""Rigid colliders (sm_collider_def), with motion scripted by a Python callable.

A motion callable is called by the library once per step and collider, as motion(t) at the step's
end time, and returns the collider's pose: `position` alone (identity rotation) or
`(position, rotation)` with rotation a unit quaternion (w, x, y, z) or None — the same contract
as a scene's Lua motion function. The library derives the collider's velocity from consecutive
poses. It is reached through one cffi callback (`_trampoline`) with a handle to a per-world
`_Motion` state. An exception inside the callable cannot cross the C library: it is recorded, the
collider keeps its last good pose for the rest of that step, and World.step / advance / run raise
the exception once the step is over.
"""
import math

from . import _fields
from ._ffi import ffi, lib
from .shapes import as_shape


class Collider:
    """A rigid collider: the union of `shapes` (a Shape or a sequence of 1..16) in the collider's
    frame, or its complement with inside_out=True.

    Keywords (sm_collider_def, same defaults): mode ("sticky", "slip" or "separate"), friction
    (Coulomb mu), inside_out, position and rotation (the pose at t = 0, sm_collider_def.pose),
    velocity and angular_velocity (constant rigid motion), or motion: a callable t -> position or
    (position, rotation) that overrides the constant velocities."""

    __slots__ = ("_c", "_motion")

    def __init__(self, shapes, *, motion=None, position=None, rotation=None, **kw):
        c = ffi.new("sm_collider_def *", lib.sm_collider_def_default())
        shapes = [shapes] if not isinstance(shapes, (list, tuple)) else list(shapes)
        if not 1 <= len(shapes) <= lib.SM_MAX_COLLIDER_SHAPES:
            raise ValueError("Collider: shapes: need 1 to %d, got %d" % (lib.SM_MAX_COLLIDER_SHAPES, len(shapes)))
        for i, s in enumerate(shapes):
            c.shapes[i] = as_shape(s, "Collider: shapes[%d]" % i)._c[0]
        c.shape_count = len(shapes)
        allowed = [f for f in _fields.settable_fields(ffi.typeof("sm_collider_def")) if f != "shape_count"]
        for key in kw:
            if key not in allowed:
                raise _fields.unknown_keyword("Collider()", key, allowed + ["motion", "position", "rotation"])
        _fields.fill(c[0], kw, "Collider()")
        if position is not None:
            c.pose.position = _fields.vector(position, 3, "Collider: position")
        if rotation is not None:
            c.pose.rotation = _fields.vector(rotation, 4, "Collider: rotation")
        if motion is not None and not callable(motion):
            raise TypeError("Collider: motion: expected a callable t -> position or (position, rotation), got %r"
                            % (motion,))
        object.__setattr__(self, "_c", c)
        object.__setattr__(self, "_motion", motion)

    def __setattr__(self, name, value):
        raise AttributeError("Collider is immutable")

    @property
    def motion(self):
        return self._motion

    @property
    def shapes(self):
        from .shapes import Shape
        out = []
        for i in range(self._c.shape_count):
            s = Shape.__new__(Shape)
            object.__setattr__(s, "_c", ffi.new("sm_shape *", self._c.shapes[i]))
            out.append(s)
        return out

    def fields(self):
        """The scalar and vector fields of the definition as a dict (mode, friction, ...)."""
        d = _fields.as_dict(self._c[0], skip=("shape_count",))
        d["position"] = tuple(self._c.pose.position)
        d["rotation"] = tuple(self._c.pose.rotation)
        return d

    def __repr__(self):
        f = self.fields()
        extra = ", motion=%r" % (self._motion,) if self._motion else ""
        return "Collider(%r, %s%s)" % (self.shapes, ", ".join("%s=%r" % kv for kv in f.items()), extra)


def pose_from(result, dim, what):
    """(position[3], rotation[4]) from a motion callable's result; raises TypeError/ValueError."""
    if isinstance(result, (tuple, list)) and len(result) == 2 and not _is_number(result[0]):
        position, rotation = result
    else:
        position, rotation = result, None
    p = _numbers(position, "%s: returned position: expected %d numbers" % (what, dim))
    if len(p) not in (dim, 3) or not all(math.isfinite(x) for x in p):
        raise ValueError("%s: returned position: expected %d finite numbers, got %r" % (what, dim, position))
    p = (p + [0.0])[:3]
    if rotation is None:
        return p, [1.0, 0.0, 0.0, 0.0]
    q = _numbers(rotation, "%s: returned rotation: expected (w, x, y, z)" % what)
    n = math.sqrt(sum(x * x for x in q)) if len(q) == 4 and all(math.isfinite(x) for x in q) else 0.0
    if not 0.5 < n < 2:
        raise ValueError("%s: returned rotation: expected a unit quaternion (w, x, y, z), got %r" % (what, rotation))
    if dim == 2 and (abs(q[1]) > 1e-9 or abs(q[2]) > 1e-9):
        raise ValueError("%s: returned rotation: in 2D a rotation must be about z, got %r" % (what, rotation))
    return p, q


def _numbers(value, expected):
    if isinstance(value, (str, bytes)):
        raise TypeError("%s, got %r" % (expected, value))
    try:
        return [float(x) for x in value]
    except (TypeError, ValueError):
        raise TypeError("%s, got %r" % (expected, value)) from None


def _is_number(x):
    return isinstance(x, (int, float)) or (hasattr(x, "dtype") and getattr(x, "ndim", 1) == 0)


class _Motion:
    """One collider's motion callable in one world: the last good pose and a pending exception."""

    def __init__(self, fn, dim, label):
        self.fn = fn
        self.dim = dim
        self.label = label
        self.last = None
        self.error = None
        self.error_time = 0.0
        self.handle = ffi.new_handle(self)

    def first_pose(self, t):
        """Calls the callable at t outside the library, raising directly (before the collider is added)."""
        self.last = pose_from(self.fn(t), self.dim, self.label)

    def fill(self, t, pose):
        if self.error is None:
            try:
                self.last = pose_from(self.fn(t), self.dim, self.label)
            except BaseException as e:  # anything: it must not unwind through C
                self.error = e
                self.error_time = t
        pose.position = self.last[0]
        pose.rotation = self.last[1]

    def take_error(self):
        e, self.error = self.error, None
        if e is not None and hasattr(e, "add_note"):
            e.add_note("raised in the motion function of %s at t = %.6g s; that step was completed with the "
                       "collider at its last good pose" % (self.label, self.error_time))
        return e


@ffi.callback("void(void *, double, sm_pose *)")
def _trampoline(user, t, pose):
    try:
        ffi.from_handle(user).fill(t, pose)
    except BaseException:  # pragma: no cover - fill() catches everything the callable raises
        pass


def attach(c, motion):
    """Points a copy of the definition at the trampoline with this motion state's handle."""
    c.motion = _trampoline
    c.motion_user = motion.handle
