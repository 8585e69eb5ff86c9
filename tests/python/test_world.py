"""World-level calls: diagnostics as a dict, time, emitters, seeding options, the frame loop."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import sandmpm as sm
from conftest import SANITIZED
from scenes import column


def test_diagnostics_has_every_field_by_name():
    with column(3, 0.04) as w:
        w.step()
        d = w.diagnostics()
        assert list(d) == [name for name, _ in sm.ffi.typeof("sm_diagnostics").fields]
        assert list(d["stage_seconds"]) == sm.stage_names() == [
            "dt", "sort", "p2g", "grid", "g2p", "plasticity", "checks", "exchange"]
        assert all(s >= 0 for s in d["stage_seconds"].values())
        assert d["particles"] == len(w) and d["steps"] == 1 and d["time"] == w.time == d["last_dt"] > 0
        masses = w.masses()
        assert d["total_mass"] == pytest.approx(float(masses.sum()), rel=1e-12)
        assert masses[0] == pytest.approx(2200 * 0.04 ** 3 / 8, rel=1e-6)
        assert len(d["momentum"]) == len(d["center_of_mass"]) == 3


def test_step_dt_none_is_the_adaptive_step():
    with column(2, 0.02) as w:
        dt = w.next_dt()
        w.step()
        assert w.time == dt
        w.step(1e-5)
        assert w.time == dt + 1e-5
        assert w.next_dt(w.time + 1e-6) == pytest.approx(1e-6)


def test_emitter_adds_its_mass_flow():
    with sm.World(dim=2, dx=0.02) as w:
        sand = sm.Material.sand()
        eid = w.add_emitter(sm.Emitter(sm.Shape.sphere((0.5, 0.7), 0.04), sand, rate=100.0, stop=0.05))
        w.advance(0.1)
        particle_mass = 2200 * 0.02 ** 2 / 8  # default ppc 8; 2D: kg per m of depth
        assert abs(w.emitted_mass(eid) - 100.0 * 0.05) <= particle_mass
        assert len(w) == round(w.emitted_mass(eid) / particle_mass) > 40
        assert float(w.masses().sum()) == pytest.approx(w.emitted_mass(eid), rel=1e-6)


def test_seeding_options_reach_the_library():
    shape = sm.Shape.box((0.5, 0.5, 0.5), (0.1, 0.1, 0.1))
    with sm.World(dx=0.05) as w:
        n8 = w.seed(shape, sm.Material.sand(), ppc=8)
        n1 = w.seed(shape, sm.Material.sand(), ppc=1, velocity=(0, 2, 0), method="poisson", seed=3)
        assert n8 == 8 * 4 ** 3
        assert 0.5 * 4 ** 3 < n1 < 1.5 * 4 ** 3
        v = w.velocities
        assert np.all(v[:n8] == 0) and np.allclose(v[n8:], (0, 2, 0))
        clip = sm.Shape.halfspace((0.5, 0.5, 0.5), (1, 0, 0))
        half = w.seed(shape, sm.Material.sand(), clip=clip)
        assert half == n8 // 2


def test_shape_distance_and_rotation():
    s = sm.Shape.sphere((0.5, 0.5, 0.5), 0.1)
    assert s.distance((0.5, 0.5, 0.5)) == pytest.approx(-0.1)
    d, g = s.distance((0.8, 0.5, 0.5), gradient=True)
    assert d == pytest.approx(0.2) and g == pytest.approx((1, 0, 0))
    box = sm.Shape.box((0, 0, 0), (1, 0.1, 0.1), rotation=sm.axis_angle((0, 0, 1), 90))
    assert box.distance((0, 0.9, 0)) < 0 < box.distance((0.9, 0, 0))
    assert sm.Shape.box((0, 0, 0), (1, 1, 1), inside_out=True).distance((0, 0, 0)) == pytest.approx(1)
    assert s.volume_estimate((0, 0, 0), (1, 1, 1)) == pytest.approx(4 / 3 * math.pi * 0.001, rel=0.02)
    assert s.replace(radius=0.2).radius == 0.2 and s.radius == 0.1


def test_installed_package_finds_the_installed_library(tmp_path):
    build = os.environ.get("SANDMPM_BUILD_DIR")
    if not build:
        pytest.fail("SANDMPM_BUILD_DIR must name the build tree (CTest's test_python sets it)")
    prefix = tmp_path / "prefix"
    subprocess.run(["cmake", "--install", build, "--prefix", str(prefix)], check=True, capture_output=True)
    pkgs = list(prefix.glob("lib/python3*/dist-packages/sandmpm/__init__.py"))
    assert len(pkgs) == 1
    env = dict(os.environ, PYTHONPATH=str(pkgs[0].parent.parent))
    env.pop("SANDMPM_LIBRARY", None)
    env.pop("SANDMPM_APP_LIBRARY", None)
    scene = os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes", "block2d.lua")
    code = ("import sandmpm as sm, sandmpm._app as a; w = sm.World(dim=2, dx=0.05); "
            "w.seed(sm.Shape.sphere((0.5, 0.5), 0.1), sm.Material.sand()); w.step(); "
            "print(sm.__file__); print(sm.library_path); print(len(w)); "
            "s = sm.load_scene(%r); print(a.app_library_path()); print(s.run('out', frames=1)['frames_written'])"
            % scene)
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True,
                         cwd=str(tmp_path)).stdout.split()
    assert out[0].startswith(str(prefix)) and out[1].startswith(str(prefix))
    assert os.path.basename(out[1]) == "libsandmpm.so.0" and int(out[2]) > 0
    assert out[3].startswith(str(prefix)) and os.path.basename(out[3]) == "libsandmpm_app.so.0"
    assert out[4] == "2" and (tmp_path / "out" / "frame_0001.ply").exists()
    assert not SANITIZED or "LD_PRELOAD" in env
