"""Particle state as NumPy arrays over the library's own storage (no copies), and their lifetime.

The library's particle arrays stay valid until the next call that steps the world or adds
particles; such a call may move them (growth, the per-step reorder). So every array handed out is a
ParticleArray registered with its world's ViewTracker, and so is every array NumPy derives from one
without copying (slices, reshapes, transposes: __array_finalize__). Before and after each call that
may move the storage, the world calls ViewTracker.retire(): every registered array becomes
read-only (writing through a stale view raises ValueError), and the next attribute access hands
out new arrays. Reading a stale array gives unspecified contents: the memory may since hold other
particles or have been handed back to the allocator.

retire() is the one seam for a later library call that keeps old storage alive while views of it
exist: it is the place that would pin the storage (and let the views go on reading the last
state) instead of only fencing writes.

Every ParticleArray holds a reference to the world's native handle, so the world's memory is freed
only when the World and all arrays over it are gone: after World.close(), arrays are read-only but
still read the last state.
"""
import weakref

import numpy as np

from ._ffi import ffi


class ParticleArray(np.ndarray):
    """An ndarray over the library's particle storage; see World (views are valid until the next
    step). Results of arithmetic and copies are plain ndarrays."""

    def __array_finalize__(self, obj):
        tracker = getattr(obj, "_sm_tracker", None)
        if tracker is not None and self.base is not None and np.may_share_memory(self, obj):
            self._sm_tracker = tracker
            self._sm_owner = obj._sm_owner
            tracker.add(self)
        else:
            self._sm_tracker = None
            self._sm_owner = None

    def __array_wrap__(self, out, context=None, return_scalar=False):
        out = out.view(np.ndarray)
        return out[()] if out.ndim == 0 else out

    def copy(self, order="C"):
        return np.array(self, order=order, copy=True).view(np.ndarray)

    def __reduce__(self):  # pickles as a plain array
        return np.asarray(self).view(np.ndarray).copy().__reduce__()


class ViewTracker:
    """The arrays over one world's storage that are still alive (weak references: ndarrays are not
    hashable, so a WeakValueDictionary keyed by id() rather than a WeakSet)."""

    def __init__(self, owner):
        self.owner = owner  # the native world handle the arrays keep alive
        self.arrays = weakref.WeakValueDictionary()
        self.cache = {}

    def add(self, array):
        self.arrays[id(array)] = array

    def retire(self):
        """The storage may move: fence every outstanding array (see the module's docstring)."""
        if self.cache:
            self.cache.clear()
        if self.arrays:
            for a in list(self.arrays.values()):
                a.flags.writeable = False
            self.arrays.clear()

    def array(self, key, ptr, shape, dtype, writable):
        """A ParticleArray of `shape` over `ptr` (cached until the next retire())."""
        a = self.cache.get(key)
        if a is not None:
            return a
        count = 1
        for s in shape:
            count *= s
        if count == 0 or ptr == ffi.NULL:
            flat = np.empty(0, dtype)
            flat.flags.writeable = False
        else:
            buf = memoryview(ffi.buffer(ptr, count * dtype.itemsize))
            flat = np.frombuffer(buf if writable else buf.toreadonly(), dtype)
        a = flat.reshape(shape).view(ParticleArray)
        a._sm_tracker = self
        a._sm_owner = self.owner
        self.add(a)
        self.cache[key] = a
        return a
