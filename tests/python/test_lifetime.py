"""World lifetime: close / with / __del__ destroy the world once; no leak over 1,000 cycles."""
import gc
import resource

import cffi
import pytest

import sandmpm as sm
from conftest import SANITIZED

_libc_ffi = cffi.FFI()
_libc_ffi.cdef("struct mallinfo2 { size_t arena, ordblks, smblks, hblks, hblkhd, usmblks, fsmblks, uordblks, "
               "fordblks, keepcost; }; struct mallinfo2 mallinfo2(void);")
_libc = _libc_ffi.dlopen(None)


def heap_in_use():
    """Bytes the C allocator has handed out and not taken back (glibc mallinfo2)."""
    m = _libc.mallinfo2()
    return m.uordblks + m.hblkhd


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize()


def cycle():
    """Everything the binding allocates per world: materials, a motion callable, particles, views."""
    with sm.World(dim=2, dx=0.05, threads=1) as w:
        sand = sm.Material.sand()
        w.add_collider(sm.Collider(sm.Shape.halfspace((0, 0.1), (0, 1))))
        w.add_collider(sm.Collider(sm.Shape.sphere((0, 0), 0.05), motion=lambda t: (0.5, 0.6 + t)))
        w.add_emitter(sm.Emitter(sm.Shape.sphere((0.5, 0.8), 0.05), sand, rate=5.0))
        w.seed(sm.Shape.box((0.5, 0.3), (0.1, 0.1)), sand, ppc=4)
        w.velocities[:, 0] += 0.1
        w.step()
        w.step()
        _ = (w.positions.sum(), w.F[0], w.diagnostics())


def test_no_leak_over_1000_create_destroy_cycles():
    for _ in range(100):  # warm up: caches, the allocator's and Python's free lists
        cycle()
    gc.collect()
    heap0, rss0, allocs0 = heap_in_use(), rss_bytes(), sm.allocation_count()
    for _ in range(500):
        cycle()
    allocs_mid = sm.allocation_count()
    for _ in range(500):
        cycle()
    gc.collect()
    heap1, rss1, allocs1 = heap_in_use(), rss_bytes(), sm.allocation_count()
    per_cycle = (allocs1 - allocs0) / 1000
    print("1000 cycles: heap %+d B, RSS %+d KiB, %.1f library allocations per cycle"
          % (heap1 - heap0, (rss1 - rss0) // 1024, per_cycle))
    # the library makes the same allocations every cycle (nothing accumulates, e.g. a growing table)
    assert allocs_mid - allocs0 == allocs1 - allocs_mid > 0
    if SANITIZED:
        return  # ASan owns the heap (mallinfo2 does not see it) and quarantines freed memory (RSS grows)
    # a leak of one library allocation per cycle (the smallest is the world) would be >= 1000 x 64 B
    assert abs(heap1 - heap0) < 32 * 1024
    assert rss1 - rss0 < 1024 * 1024


def test_close_is_idempotent_and_the_with_block_closes(counting):
    w = sm.World(dim=2, dx=0.05)
    p = address(w)
    w.close()
    assert w.closed and counting.destroyed == [p]  # no view was alive: destroyed at once
    w.close()
    assert counting.destroyed == [p]
    with sm.World(dim=2, dx=0.05) as w2:
        assert not w2.closed
    assert w2.closed
    assert repr(w2) == "<sandmpm.World (closed)>"
    with pytest.raises(ValueError, match="closed"):
        len(w2)


class CountingLib:
    """Forwards to the library, counting sm_world_destroy calls per pointer."""

    def __init__(self, lib):
        self._lib = lib
        self.destroyed = []

    def sm_world_destroy(self, ptr):
        self.destroyed.append(int(sm.ffi.cast("uintptr_t", ptr)))
        self._lib.sm_world_destroy(ptr)

    def __getattr__(self, name):
        return getattr(self._lib, name)


@pytest.fixture
def counting(monkeypatch):
    c = CountingLib(sm.lib)
    monkeypatch.setattr(sm.world, "lib", c)
    return c


def address(w):
    return int(sm.ffi.cast("uintptr_t", w._w))


def test_each_world_is_destroyed_exactly_once(counting):
    a = sm.World(dim=2, dx=0.05)
    pa = address(a)
    del a  # garbage: __del__
    gc.collect()
    b = sm.World(dim=2, dx=0.05)
    pb = address(b)
    b.close()
    b.close()
    del b
    with sm.World(dim=2, dx=0.05) as c:
        pc = address(c)
    c.__del__()
    del c
    gc.collect()
    assert counting.destroyed == [pa, pb, pc]


def test_a_view_outliving_its_world_defers_destruction(counting):
    w = sm.World(dim=2, dx=0.05)
    w.seed(sm.Shape.box((0.5, 0.5), (0.1, 0.1)), sm.Material.sand())
    p = address(w)
    x = w.positions[:, 1]
    first = x.copy()
    w.close()
    gc.collect()
    assert counting.destroyed == []  # the slice keeps the world's memory: reading it is safe
    assert (x == first).all() and not x.flags.writeable
    del x
    gc.collect()
    assert counting.destroyed == [p]
