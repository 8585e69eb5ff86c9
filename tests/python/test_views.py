"""Particle state as NumPy views of the library's memory: shapes, aliasing, and stale views."""
import gc

import numpy as np
import pytest

import sandmpm as sm
from scenes import column


@pytest.fixture
def world():
    w = column(3, 0.04)
    yield w
    w.close()


def test_views_have_the_library_layout(world):
    n, d = len(world), 3
    assert n == world.diagnostics()["particles"] > 1000
    assert world.positions.shape == world.velocities.shape == (n, d)
    assert world.B.shape == world.F.shape == (n, d, d)
    for a in (world.q, world.alpha, world.volume, world.material):
        assert a.shape == (n,)
    assert world.positions.dtype == np.float64  # positions are double in both builds
    assert world.velocities.dtype == sm.real_dtype == (np.float64 if sm.real_is_double else np.float32)
    assert world.material.dtype == np.uint16
    # freshly seeded: undeformed, V0 = dx^3 / ppc, one material
    eye = np.eye(d, dtype=sm.real_dtype)
    assert np.array_equal(world.F, np.broadcast_to(eye, (n, d, d)))
    assert np.allclose(world.volume, 0.04 ** 3 / 8, rtol=1e-6)
    assert set(np.unique(world.material)) == {0}


def test_views_alias_library_memory_without_copies(world):
    p = sm.ffi.new("sm_particles_view *")
    sm.lib.sm_world_particles(world._w, p)
    assert world.positions.ctypes.data == int(sm.ffi.cast("uintptr_t", p.x))
    assert world.F.ctypes.data == int(sm.ffi.cast("uintptr_t", p.F))
    # the centre of mass from the views equals the library's (uniform masses: one material, one V0)
    com = world.positions.astype(np.float64).mean(axis=0)
    assert np.allclose(com, world.diagnostics()["center_of_mass"], rtol=0, atol=1e-9)


def test_velocity_write_is_seen_by_the_library(world):
    world.step()
    v = world.velocities
    v[:] = 0
    v[:, 0] = 2.0  # everything moves +x at 2 m/s
    d = world.diagnostics()
    assert d["max_speed"] == pytest.approx(2.0)
    assert d["momentum"][0] == pytest.approx(2.0 * d["total_mass"], rel=1e-6)
    assert d["kinetic_energy"] == pytest.approx(0.5 * d["total_mass"] * 4.0, rel=1e-6)
    # the next step's dt respects the new speed (CFL: cfl dx / vmax = 0.04 / 2)
    assert world.next_dt() <= 0.04 / 2.0


def test_only_velocities_are_writable(world):
    for name in ("positions", "B", "F", "q", "alpha", "volume", "material"):
        a = getattr(world, name)
        with pytest.raises(ValueError, match="read-only"):
            a[0] = 0
        with pytest.raises(ValueError):
            a.flags.writeable = True  # a read-only buffer underneath
    world.velocities[0, 0] = 1.0
    assert float(world.velocities[0, 0]) == 1.0


def test_views_become_read_only_after_a_step_with_their_slices(world):
    v = world.velocities
    vx = v[:, 0]            # a slice: another ndarray over the same memory
    flat = v.reshape(-1)
    top = world.positions[10:20]
    kept = v.copy()         # a copy is the caller's own memory
    world.step()
    for stale in (v, vx, flat, top):
        assert not stale.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        v[0, 0] = 1
    with pytest.raises(ValueError, match="read-only"):
        vx[0] = 1
    kept[0, 0] = 123.0      # copies stay writable and are plain arrays
    assert type(kept) is np.ndarray and kept.flags.writeable
    fresh = world.velocities
    assert fresh is not v and fresh.flags.writeable
    fresh[0, 0] = 0.25
    assert float(world.velocities[0, 0]) == 0.25


def test_views_become_read_only_when_particles_are_added(world):
    x = world.positions
    v = world.velocities
    n = len(world)
    added = world.seed(sm.Shape.sphere((0.5, 0.7, 0.5), 0.05), sm.Material.elastic(), ppc=8)
    assert added > 0 and len(world) == n + added
    assert not v.flags.writeable and not x.flags.writeable
    assert world.positions.shape == (n + added, 3)
    assert set(np.unique(world.material)) == {0, 1}
    world.add_particles([[0.5, 0.9, 0.5]], material=0, velocities=[[0.0, -1.0, 0.0]])
    assert len(world) == n + added + 1
    # add_particles keeps the given state until a step (no reorder in between)
    assert tuple(world.positions[-1]) == pytest.approx((0.5, 0.9, 0.5))
    assert tuple(world.velocities[-1]) == pytest.approx((0.0, -1.0, 0.0))


def test_arithmetic_on_views_gives_plain_arrays(world):
    x = world.positions
    assert type(x) is sm.ParticleArray
    assert type(x + 1) is np.ndarray
    assert type(np.sin(x)) is np.ndarray
    assert isinstance(x.mean(), np.floating)
    assert type(x.sum(axis=0)) is np.ndarray
    assert x[0, 0] == world.positions[0, 0]


def test_views_keep_the_memory_after_close():
    w = column(2, 0.02)
    x = w.positions
    first = x.copy()
    w.close()
    gc.collect()
    assert w.closed and not x.flags.writeable
    assert np.array_equal(x, first)  # still the library's storage, freed only when x goes
    with pytest.raises(ValueError, match="closed"):
        w.positions
    with pytest.raises(ValueError, match="closed"):
        w.step()


def test_empty_world_has_empty_views():
    with sm.World(dim=2, dx=0.05) as w:
        assert len(w) == 0
        assert w.positions.shape == (0, 2) and w.F.shape == (0, 2, 2)
        assert w.velocities.shape == (0, 2)
