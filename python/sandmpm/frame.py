"""Frames (app/frame.h) read back from PLY files or taken from a world, and the preview renderer
(app/render.h) drawing them into NumPy images."""
import os

import numpy as np

from ._app import app
from ._ffi import ErrBuf, ffi

_COLORS = {"sand": 0, "speed": 1, "material": 2, "q": 3}


class Frame:
    """One frame of particles as the renderer and the readers see it (sm_frame): float32 positions
    (n, 3; z = 0 in 2D), velocities (n, 3), q (n), volume (n, or None), material (n, uint16), ids
    (n, uint32, or None), dim and domain ((min, max) or None). The arrays are copies (the frame's
    memory is freed when the Frame goes)."""

    def __init__(self, cframe):
        f = cframe[0]
        n = f.n

        def arr(ptr, count, dtype):
            if ptr == ffi.NULL:
                return None
            return np.frombuffer(ffi.buffer(ptr, count * np.dtype(dtype).itemsize), dtype=dtype).copy()

        self.dim = f.dim
        self.positions = arr(f.x, 3 * n, np.float32).reshape(n, 3)
        self.velocities = arr(f.v, 3 * n, np.float32).reshape(n, 3)
        self.q = arr(f.q, n, np.float32)
        self.volume = arr(f.volume, n, np.float32)
        self.material = arr(f.material, n, np.uint16)
        self.ids = arr(f.id, n, np.uint32)
        self.has_velocity, self.has_q, self.has_material = bool(f.has_velocity), bool(f.has_q), bool(f.has_material)
        self.domain = (tuple(f.domain_min), tuple(f.domain_max)) if f.has_domain else None

    def __len__(self):
        return self.positions.shape[0]

    def __repr__(self):
        return "<sandmpm.Frame %dD, %d particles>" % (self.dim, len(self))

    def _cframe(self):
        """A new sm_frame over this frame's arrays (kept alive by the returned tuple)."""
        f = ffi.new("sm_frame *")
        n = len(self)
        keep = []

        def ptr(a, ctype, dtype):
            if a is None:
                return ffi.NULL
            a = np.ascontiguousarray(a, dtype=dtype)
            keep.append(a)
            return ffi.cast(ctype, ffi.from_buffer(a))

        f.n, f.dim = n, self.dim
        f.x = ptr(self.positions, "float *", np.float32)
        f.v = ptr(self.velocities, "float *", np.float32)
        f.q = ptr(self.q, "float *", np.float32)
        f.volume = ptr(self.volume, "float *", np.float32)
        f.material = ptr(self.material, "uint16_t *", np.uint16)
        f.id = ptr(self.ids, "uint32_t *", np.uint32)
        f.has_velocity, f.has_q, f.has_material = self.has_velocity, self.has_q, self.has_material
        if self.domain is not None:
            f.has_domain = 1
            f.domain_min = list(self.domain[0])
            f.domain_max = list(self.domain[1])
        return f, keep


def _take(cframe):
    try:
        return Frame(cframe)
    finally:
        app().sm_frame_free(cframe)


def read_frame(path):
    """Reads a PLY frame (sm_ply_read: sandmpm's frame files or any PLY with x y [z] ...)."""
    f = ffi.new("sm_frame *")
    err = ErrBuf()
    st = app().sm_ply_read(os.fsencode(path), f, err.buf, err.SIZE)
    if st != 0:
        raise err.error(st)
    return _take(f)


def frame_from_world(world):
    """The world's particles as a Frame, in id order, as the frame files hold them
    (sm_frame_from_world)."""
    f = ffi.new("sm_frame *")
    err = ErrBuf()
    st = app().sm_frame_from_world(world._w, f, err.buf, err.SIZE)
    if st != 0:
        raise err.error(st)
    return _take(f)


def write_ply(world, path, z_up=False):
    """Writes the world's particles as `sandmpm run` writes frame_NNNN.ply (sm_write_ply)."""
    err = ErrBuf()
    st = app().sm_write_ply(world._w, os.fsencode(path), int(bool(z_up)), err.buf, err.SIZE)
    if st != 0:
        raise err.error(st)


def render(frame, width=1280, height=720, color="sand", color_range=None, radius_scale=1.0, shadows=True,
           legend=False, threads=0, seed=1, camera=None, ground=None):
    """Renders a Frame (or a World: its particles, sm_frame_from_world) with the preview renderer
    (sm_render; sm_render_opts' defaults, the camera fitted to the frame's domain) and returns the
    image as a NumPy uint8 array (height, width, 3), row 0 at the top. color: "sand", "speed",
    "material" or "q"; color_range: (lo, hi) of the speed or q map (None: 0 .. the frame's max).
    camera: None (fitted), or a dict with eye, target, up (default (0, 1, 0)) and fov (degrees,
    default 40; <= 0: orthographic) — a Scene's settings will do (used if its has_camera is set).
    ground: None (at the domain's bottom), False (none) or a height y (m). Colliders are not drawn
    (a run's renders, Scene.run(render=True), draw them)."""
    if not isinstance(frame, Frame):
        frame = frame_from_world(frame)
    o = ffi.new("sm_render_opts *", app().sm_render_opts_default())
    o.width, o.height = int(width), int(height)
    if color not in _COLORS:
        raise ValueError("render: color must be one of %s, got %r" % (", ".join(_COLORS), color))
    o.color = _COLORS[color]
    if color_range is not None:
        o.color_range = [float(color_range[0]), float(color_range[1])]
    o.radius_scale = float(radius_scale)
    o.shadows = int(bool(shadows))
    o.legend = int(bool(legend))
    o.threads = int(threads)
    o.seed = int(seed)
    if ground is False:
        o.ground = 1  # SM_GROUND_NONE
    elif ground is not None:
        o.ground, o.ground_y = 2, float(ground)  # SM_GROUND_AT
    if camera is not None and camera.get("has_camera", 1):
        o.has_camera = 1
        o.camera.eye = [float(c) for c in camera["eye"]]
        o.camera.target = [float(c) for c in camera["target"]]
        o.camera.up = [float(c) for c in camera.get("up", (0, 1, 0))]
        o.camera.fov_deg = float(camera.get("fov", 40))
    if not (1 <= o.width <= 16384 and 1 <= o.height <= 16384):
        raise ValueError("render: width and height must be 1..16384, got %d x %d" % (o.width, o.height))
    rgb = np.zeros((o.height, o.width, 3), dtype=np.uint8)
    f, keep = frame._cframe()
    err = ErrBuf()
    st = app().sm_render(f, o, ffi.cast("uint8_t *", ffi.from_buffer(rgb)), err.buf, err.SIZE)
    del keep
    if st != 0:
        raise err.error(st)
    return rgb


def write_png(path, rgb):
    """Writes an (height, width, 3) uint8 image as a PNG file (sm_png_write, as the renders)."""
    rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError("write_png: expected an array (height, width, 3), got shape %s" % (rgb.shape,))
    err = ErrBuf()
    st = app().sm_png_write(os.fsencode(path), rgb.shape[1], rgb.shape[0], ffi.cast("uint8_t *", ffi.from_buffer(rgb)),
                            err.buf, err.SIZE)
    if st != 0:
        raise err.error(st)
