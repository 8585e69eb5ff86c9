"""Lua scenes from Python (sandmpm.load_scene, Scene.run) against the command line: the same scene,
parameters and quality give the same files, byte for byte (diagnostics.csv: all but its wall-clock
columns); stepping the scene's world from Python gives the C program's frames; the loader's
errors arrive with their messages; render() draws what `sandmpm run --render` draws."""
import math
import os
import subprocess

import numpy as np
import pytest

import sandmpm as sm

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULT = os.path.join(ROOT, "scenes", "default.lua")
BLOCK2D = os.path.join(ROOT, "tests", "python", "scenes", "block2d.lua")
WALL_COLUMNS = ("wall_s_frame", "wall_s_total")


def sandmpm_program():
    build = os.environ.get("SANDMPM_BUILD_DIR")
    exe = os.path.join(build, "sandmpm") if build else None
    if not exe or not os.path.exists(exe):
        pytest.fail("SANDMPM_BUILD_DIR must name the build folder holding the sandmpm program (CTest sets it)")
    return exe


def cli_run(scene, out, *args):
    subprocess.run([sandmpm_program(), "run", scene, "--out", str(out), "-q", *args], check=True)


def files(folder):
    found = {}
    for dirpath, _, names in os.walk(folder):
        for n in names:
            p = os.path.join(dirpath, n)
            found[os.path.relpath(p, folder)] = p
    return found


def diagnostics_without_wall(path):
    with open(path) as f:
        rows = [line.rstrip("\n").split(",") for line in f]
    keep = [i for i, name in enumerate(rows[0]) if name not in WALL_COLUMNS]
    assert len(keep) == len(rows[0]) - len(WALL_COLUMNS)
    return [[r[i] for i in keep] for r in rows]


def same_checkpoint(path_a, path_b):
    """Checkpoint files agree but for the stage timings (sm_world_save keeps the wall-clock
    stage_seconds: two runs of the program differ there too) and the crc32 that covers them."""
    with open(path_a, "rb") as fa, open(path_b, "rb") as fb:
        a, b = np.frombuffer(fa.read(), np.uint8), np.frombuffer(fb.read(), np.uint8)
    assert a.size == b.size > 1000
    diff = np.nonzero(a != b)[0]
    body = diff[diff < a.size - 4]
    if body.size:
        assert body.max() - body.min() < 8 * len(sm.stage_names()), (body.min(), body.max())
    return True


def test_run_writes_the_command_lines_files(tmp_path):
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    cli_run(DEFAULT, cli_out, "--quality", "test", "--set", "dx=0.05", "--render", "--checkpoint-every", "1")
    with sm.load_scene(DEFAULT, quality="test", dx=0.05) as scene:
        seen = []
        result = scene.run(str(py_out), render=True, checkpoint_every=1,
                           on_frame=lambda s, f: seen.append((f, s.world.time, len(s.world))))
    assert result == {"frames_written": 3, "stopped": False}
    assert [f for f, _, _ in seen] == [0, 1, 2]
    assert [t for _, t, _ in seen] == [0.0, 1 / 24, 2 / 24]
    a, b = files(cli_out), files(py_out)
    assert sorted(a) == sorted(b)
    for name in ("frame_0002.ply", "frame_0002.vtp", "frame_0002.png", "run_manifest.txt", "frames.pvd",
                 "render.txt", "poses.csv", os.path.join("checkpoints", "ckpt_00000002.smc")):
        assert name in a
    for name in a:
        if name == "diagnostics.csv":
            da, db = diagnostics_without_wall(a[name]), diagnostics_without_wall(b[name])
            assert len(da) == 4 and da == db
        elif name.endswith(".smc"):
            assert same_checkpoint(a[name], b[name])
        else:
            with open(a[name], "rb") as fa, open(b[name], "rb") as fb:
                assert fa.read() == fb.read(), name


def test_a_lua_motion_function_moves_the_collider_as_in_the_program(tmp_path):
    butterfly = os.path.join(ROOT, "scenes", "butterfly.lua")  # colliders[1].motion is a Lua function
    cli_run(butterfly, tmp_path / "cli", "--quality", "test", "--checkpoint-every", "0")
    with sm.load_scene(butterfly, quality="test") as scene:
        assert scene.run(str(tmp_path / "py"), checkpoint_every=0)["frames_written"] == scene.settings["frames"] + 1
        assert scene.motion_error is None
    a, b = files(tmp_path / "cli"), files(tmp_path / "py")
    assert sorted(a) == sorted(b) and "poses.csv" in a
    with open(a["poses.csv"]) as f:  # frame, collider, position, rotation
        poses = {(int(r[0]), int(r[1])): [float(v) for v in r[2:5]] for r in (line.split(",") for line in f)}
    for f in range(3):  # the stylus descends: y = 0.1 + 0.08 (1 - t / 0.25) for t < 0.25 s
        assert poses[(f, 1)][1] == pytest.approx(0.18 - 0.32 * f / 24, abs=1e-12)
    for name in a:
        if name == "diagnostics.csv":
            assert diagnostics_without_wall(a[name]) == diagnostics_without_wall(b[name])
        else:
            with open(a[name], "rb") as fa, open(b[name], "rb") as fb:
                assert fa.read() == fb.read(), name


def test_a_second_run_replaces_the_first_and_another_scene_is_refused(tmp_path):
    out = str(tmp_path / "out")
    with sm.load_scene(DEFAULT, quality="test", dx=0.05) as scene:
        scene.run(out, frames=1)
    with sm.load_scene(DEFAULT, quality="test", dx=0.05) as scene:  # the same run: replaced
        assert scene.run(out, frames=1, checkpoint_every=0)["frames_written"] == 2
    with sm.load_scene(DEFAULT, quality="test", dx=0.06) as scene:
        with pytest.raises(sm.Error) as e:
            scene.run(out, frames=1)
        assert e.value.status == sm.Status.ERR_INVALID
        assert "holds the frames of another run" in e.value.message and "overwrite" in e.value.message
        assert scene.run(out, frames=1, overwrite=True)["frames_written"] == 2
        with pytest.raises(ValueError, match="load it again"):
            scene.run(out)
    with open(os.path.join(out, "run_manifest.txt")) as f:
        assert "frames 1\n" in f.read()


def test_on_frame_stops_and_raises(tmp_path):
    with sm.load_scene(DEFAULT, quality="test", dx=0.05) as scene:
        assert scene.run(str(tmp_path / "a"), on_frame=lambda s, f: f == 1) == {"frames_written": 2, "stopped": True}
    with open(tmp_path / "a" / "run_manifest.txt") as f:
        text = f.read()
    assert "state stopped\n" in text and "frame_files ply 0 1\n" in text

    def boom(scene, frame):
        raise KeyError("boom at %d" % frame)

    with sm.load_scene(DEFAULT, quality="test", dx=0.05) as scene:
        with pytest.raises(KeyError, match="boom at 0"):
            scene.run(str(tmp_path / "b"), on_frame=boom)


def test_advancing_the_scenes_world_gives_the_c_programs_frames(tmp_path):
    cli_run(DEFAULT, tmp_path / "cli", "--quality", "test", "--set", "dx=0.05", "--checkpoint-every", "0")
    with sm.load_scene(DEFAULT, quality="test", dx=0.05) as scene:
        w = scene.world
        fps = scene.settings["fps"]
        assert fps == 24 and scene.settings["frames"] == 2 and scene.materials == ["sand"]
        for f in range(3):
            if f:
                w.advance(f / fps)
            sm.write_ply(w, str(tmp_path / ("py_%d.ply" % f)))
            with open(tmp_path / "cli" / ("frame_%04d.ply" % f), "rb") as a, open(tmp_path / ("py_%d.ply" % f), "rb") as b:
                assert a.read() == b.read(), f
        # The frame read back is the world's state: the same float32 positions (the file in id
        # order, the world in its own; both sorted here).
        fr = sm.read_frame(str(tmp_path / "cli" / "frame_0002.ply"))
        assert len(fr) == len(w) == 713 and fr.dim == 3
        a, b = fr.positions, w.positions.astype(np.float32)
        assert np.array_equal(a[np.lexsort(a.T)], b[np.lexsort(b.T)])


def test_the_scenes_world_outlives_close_while_arrays_hold_it():
    scene = sm.load_scene(DEFAULT, quality="test", dx=0.05)
    x = scene.world.positions
    first = x.copy()
    scene.close()
    assert scene.closed
    assert np.array_equal(x, first)  # the scene's memory is still held by the array
    with pytest.raises(ValueError):
        x[0, 0] = 1
    with pytest.raises(ValueError, match="closed"):
        scene.world


def test_bad_scenes_and_parameters_raise_the_loaders_message(tmp_path, monkeypatch):
    with pytest.raises(sm.Error) as e:
        sm.load_scene(DEFAULT, quality="test", foo=1)
    assert e.value.status == sm.Status.ERR_INVALID
    assert e.value.message == "%s: --set foo=1: the scene does not use params.foo" % DEFAULT
    monkeypatch.chdir(tmp_path)  # a short path: Lua shortens long chunk names in its messages ("...")
    bad = "bad.lua"
    with open(bad, "w") as f:
        f.write("return {\n  dim = 3, frames = 2,\n  dx = -1,\n}\n")
    with pytest.raises(sm.Error) as e:
        sm.load_scene(bad)
    assert e.value.status == sm.Status.ERR_INVALID
    assert e.value.message.startswith("bad.lua:3: dx"), e.value.message
    with open(bad, "w") as f:
        f.write("return {\n  dim = 3, frames = 2\n  dx = 1 }\n")
    with pytest.raises(sm.Error) as e:
        sm.load_scene(bad)
    assert e.value.message == "bad.lua:3: '}' expected (to close '{' at line 1) near 'dx'"
    with pytest.raises(sm.Error) as e:
        sm.load_scene(str(tmp_path / "missing.lua"))
    assert e.value.status == sm.Status.ERR_IO and "missing.lua" in e.value.message
    with pytest.raises(sm.Error) as e:
        sm.load_scene(DEFAULT, quality="best")
    assert "best" in e.value.message
    with sm.load_scene(DEFAULT, quality="test", dx=0.05) as scene:
        with pytest.raises(ValueError, match="frames or end"):
            scene.run(str(tmp_path / "x"), frames=1, end=0.1)
        assert scene.frame_count(end=0.1) == math.ceil(0.1 * 24)


def test_render_is_the_runs_render_and_covers_the_sand(tmp_path):
    cli_run(BLOCK2D, tmp_path / "cli", "--render", "--checkpoint-every", "0")
    for f in (0, 2):
        frame = sm.read_frame(str(tmp_path / "cli" / ("frame_%04d.ply" % f)))
        img = sm.render(frame)
        assert img.shape == (720, 1280, 3) and img.dtype == np.uint8
        sm.write_png(str(tmp_path / "py.png"), img)
        with open(tmp_path / "cli" / ("frame_%04d.png" % f), "rb") as a, open(tmp_path / "py.png", "rb") as b:
            assert a.read() == b.read(), f
    # Frame 0: the block as seeded. The view is the domain (1 x 0.6 m) grown by 5% on each side,
    # fitted to the image's height: 720 / 0.66 px per m, centred on (0.5, 0.3).
    frame = sm.read_frame(str(tmp_path / "cli" / "frame_0000.ply"))
    empty = sm.read_frame(str(tmp_path / "cli" / "frame_0000.ply"))
    for k in ("positions", "velocities", "q", "volume", "material", "ids"):
        setattr(empty, k, getattr(empty, k)[:0])
    sand = (sm.render(frame) != sm.render(empty)).any(axis=2)
    rows, cols = np.nonzero(sand)
    s = 720 / 0.66
    r = math.sqrt(frame.volume[0] / 2) * s  # a grain's radius in pixels (2D: sqrt(V/2))
    x, y = frame.positions[:, 0], frame.positions[:, 1]
    assert abs(cols.min() - ((x.min() - 0.5) * s + 640 - r)) < 1.5
    assert abs(cols.max() - ((x.max() - 0.5) * s + 640 + r)) < 1.5
    assert abs(rows.min() - (360 - (y.max() - 0.3) * s - r)) < 1.5
    assert abs(rows.max() - (360 - (y.min() - 0.3) * s + r)) < 1.5
    box = (cols.max() - cols.min() + 1) * (rows.max() - rows.min() + 1)
    assert sand.sum() > 0.8 * box
    # From a world: the same picture as from its frame file.
    with sm.load_scene(BLOCK2D) as scene:
        assert np.array_equal(sm.render(scene.world, width=320, height=180),
                              sm.render(frame, width=320, height=180))
    with pytest.raises(ValueError, match="color"):
        sm.render(frame, color="pink")
