"""Lua scene files from Python: load_scene (the command line's loader, app/scene.h) and Scene.run
(the same outputs as `sandmpm run`, app/scene_run.h)."""
import math
import os

from ._app import app
from ._ffi import Error, ErrBuf, ffi
from .world import World


def _param_text(value):
    """A --set VALUE as the command line would be given it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


class _SceneNative:
    """Owns the sm_scene pointer; the scene (and its world) is destroyed when the last reference
    goes: the Scene, its World, or a particle array over that world."""

    __slots__ = ("ptr",)

    def __init__(self, ptr):
        self.ptr = ptr

    def __del__(self):
        if self.ptr is not None:
            ptr, self.ptr = self.ptr, None
            try:
                app().sm_scene_destroy(ptr)
            except Exception:  # interpreter shutdown
                pass


class Scene:
    """A loaded (and, unless load_scene(build=False), built) scene. `world` is its World, owned by
    the scene: close() (or a with-block) closes it too, and arrays still alive over it keep the
    scene's memory, read-only, until they go. `settings` is the loader's view of the file (fps,
    frames, outputs, camera, estimates), `warnings` what it found suspicious ("PATH:LINE: ...")."""

    def __init__(self, path, quality="preview", threads=0, params=None, build=True):
        self.path = os.fspath(path)
        self.quality = quality
        self.threads = int(threads)
        self.params = {str(k): _param_text(v) for k, v in (params or {}).items()}
        keys = [ffi.new("char[]", k.encode()) for k in self.params]
        values = [ffi.new("char[]", v.encode()) for v in self.params.values()]
        self._cparams = ffi.new("sm_scene_param[]", max(1, len(keys)))
        for i, (k, v) in enumerate(zip(keys, values)):
            self._cparams[i].key, self._cparams[i].value = k, v
        self._cstrings = keys + values
        self._cpath = ffi.new("char[]", os.fsencode(self.path))
        self._cquality = ffi.new("char[]", quality.encode()) if quality is not None else ffi.NULL
        out = ffi.new("sm_scene **")
        err = ErrBuf()
        st = app().sm_scene_load(self._cpath, ffi.NULL, self._cparams, len(keys), self._cquality, int(threads), out,
                                 err.buf, err.SIZE)
        if st != 0:
            raise err.error(st)
        self._native = _SceneNative(out[0])
        self._world = None
        if build:
            self.build()

    # -- lifetime --------------------------------------------------------------------------

    @property
    def _s(self):
        if self._native is None:
            raise ValueError("sandmpm.Scene: the scene is closed")
        return self._native.ptr

    def close(self):
        """Closes the scene and its World (their memory goes once no particle array holds it)."""
        if self._world is not None:
            self._world.close()
            self._world = None
        self._native = None

    @property
    def closed(self):
        return self._native is None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        if self.closed:
            return "<sandmpm.Scene (closed)>"
        return "<sandmpm.Scene %r quality=%r>" % (self.path, self.quality)

    # -- what the loader found -------------------------------------------------------------

    def build(self):
        """Creates the world (sm_scene_build): materials, colliders, seeded objects, emitters. Once."""
        err = ErrBuf()
        st = app().sm_scene_build(self._s, err.buf, err.SIZE)
        if st != 0:
            raise err.error(st)

    @property
    def built(self):
        return app().sm_scene_world(self._s) != ffi.NULL

    @property
    def settings(self):
        """The scene's settings (sm_scene_settings) as a dict."""
        s = app().sm_scene_get_settings(self._s)
        d = {name: getattr(s, name) for name, _ in ffi.typeof("sm_scene_settings").fields}
        d["name"] = ffi.string(s.name).decode(errors="replace")
        for k in ("eye", "target", "up"):
            d[k] = tuple(getattr(s, k))
        return d

    @property
    def warnings(self):
        a = app()
        n = min(a.sm_scene_warning_count(self._s), 16)
        return [ffi.string(a.sm_scene_warning(self._s, i)).decode(errors="replace") for i in range(n)]

    @property
    def materials(self):
        """The scene's material names in id order (as the PLY files' material ids)."""
        a = app()
        return [ffi.string(a.sm_scene_material_name(self._s, i)).decode()
                for i in range(a.sm_scene_material_count(self._s))]

    @property
    def motion_error(self):
        """None, or the first error of a collider's Lua motion function."""
        e = app().sm_scene_motion_error(self._s)
        return None if e == ffi.NULL else ffi.string(e).decode(errors="replace")

    @property
    def world(self):
        """The scene's World (owned by the scene). Stepping it from Python takes the same steps as a
        run; a Lua motion function's error is then in motion_error."""
        if self._world is None:
            w = app().sm_scene_world(self._s)
            if w == ffi.NULL:
                raise ValueError("sandmpm.Scene: the scene is not built (Scene.build())")
            self._world = World._borrow(w, self._native)
        return self._world

    # -- a run -----------------------------------------------------------------------------

    def frame_count(self, frames=None, end=None):
        """Frames after frame 0 for frames= or end= (seconds, rounded up to whole frames as
        `sandmpm run --end`), else the scene's."""
        if frames is not None and end is not None:
            raise ValueError("Scene.run: give frames or end, not both")
        fps = self.settings["fps"]
        if end is not None:
            if not end > 0:
                raise ValueError("Scene.run: end must be seconds > 0, got %r" % (end,))
            return int(math.ceil(end * fps - 1e-9))
        if frames is not None:
            if int(frames) < 1:
                raise ValueError("Scene.run: frames must be >= 1, got %r" % (frames,))
            return int(frames)
        return self.settings["frames"]

    def run(self, out, frames=None, end=None, render=False, overwrite=False, checkpoint_every=None,
            keep_checkpoints=None, threads=None, on_frame=None):
        """Runs the built scene into folder `out` with the files `sandmpm run SCENE --out OUT
        --quality Q --set K=V ...` writes (frame_NNNN.ply/.vtp, frames.pvd, diagnostics.csv,
        render.txt, poses.csv, run_manifest.txt, checkpoints/; render=True: frame_NNNN.png as
        --render), frames 0..frames (frames=/end= as --frames/--end, else the scene's).
        checkpoint_every: frames between checkpoints (None: the scene's, else 20; 0: none);
        keep_checkpoints: how many are kept (None: 2); threads: the renderer's (None: the scene's, as
        the program's --threads serves both). overwrite: another
        run's files in out are removed first (as --overwrite); an earlier run of the same scene,
        quality and parameters is replaced without it. on_frame(scene, frame), if given, runs once
        every file of the frame is written; returning True stops the run (the manifest then says
        "stopped"); an exception it raises stops the run and is raised. Returns
        {"frames_written": N, "stopped": bool}. Raises sandmpm.Error with the run's message."""
        world = self.world
        if world.time != 0:
            raise ValueError("Scene.run: the world is at t = %g s; a run starts from the scene as built "
                             "(load it again)" % world.time)
        o = ffi.new("sm_scene_run_opts *", app().sm_scene_run_opts_default())
        cout = ffi.new("char[]", os.fsencode(os.fspath(out)))
        o.out, o.scene, o.quality = cout, self._cpath, self._cquality
        o.params, o.nparams = self._cparams, len(self.params)
        o.frames = self.frame_count(frames, end)
        o.render = int(bool(render))
        o.threads = self.threads if threads is None else int(threads)
        o.checkpoint_every = -1 if checkpoint_every is None else int(checkpoint_every)
        o.keep = 0 if keep_checkpoints is None else int(keep_checkpoints)
        o.overwrite = int(bool(overwrite))
        raised = []
        if on_frame is not None:
            @ffi.callback("int(void *, int)")
            def hook(ctx, frame):
                try:
                    stop = bool(on_frame(self, frame))
                except BaseException as e:  # carried across the C frame loop, raised below
                    raised.append(e)
                    stop = True
                world._views.retire()
                return 1 if stop else 0
            o.on_frame = hook
        written, stopped = ffi.new("int *"), ffi.new("int *")
        err = ErrBuf()
        world._views.retire()
        try:
            st = app().sm_scene_run(self._s, o, written, stopped, err.buf, err.SIZE)
        finally:
            world._views.retire()
        if raised:
            raise raised[0]
        if st != 0:
            raise err.error(st)
        return {"frames_written": written[0], "stopped": bool(stopped[0])}


def load_scene(path, quality="preview", threads=0, build=True, params=None, **kw):
    """Loads a Lua scene file as `sandmpm run` does (sm_scene_load, then sm_scene_build unless
    build=False): quality "preview", "paper" or "test"; threads for the world (0: OpenMP's
    default); every other keyword (and every key of params=, for names such as "quality") is a
    --set KEY=VALUE (True/False as true/false, numbers as Python writes them). A bad file or
    parameter raises sandmpm.Error with the loader's message ("PATH:LINE: ...")."""
    merged = dict(params or {})
    merged.update(kw)
    return Scene(path, quality=quality, threads=threads, params=merged, build=build)
