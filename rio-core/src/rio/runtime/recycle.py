"""Recycled copy buffers: a reader's private copies of large samples without paying page faults on each.

Every checked read copies a slot into memory of its own (`rio.runtime.buffers`, `rio.runtime.slot_check`), and a fresh
allocation the size of a camera frame is not free: the C allocator serves it with a new mapping, or gives
it back to the system when freed, so each copy of a 640x480 frame first faults in ~225 pages. On a
virtual machine that costs several times the copy itself (~0.6 ms against ~0.1 ms per frame, measured
here), and a control loop reading three cameras and a policy node reading them again pay it on every
observation.

A pool keeps a few buffers and hands one out again only once nothing made from it is alive: no array,
view, record or memoryview of it (each holds a reference to it, directly or through the view it came
from, and CPython's reference count is exact). So a reader may keep a frame as long as it likes and it
never changes under it; when every pooled buffer is still held, a new one is allocated, as without a pool.
This is the allocator's own rule (memory is reused once freed), applied a step earlier.
Where reference counts are not exact (a free-threaded build, PyPy), the pool is off and every take allocates.
"""

from __future__ import annotations

import sys
import threading

import numpy as np

#: Records smaller than this come from the allocator's heap without faults: no pool.
MIN_POOLED_BYTES = 64 * 1024
_EXACT_REFCOUNTS = hasattr(sys, "getrefcount") and getattr(sys, "_is_gil_enabled", lambda: True)()


def _count(bufs: list[np.ndarray], i: int) -> int:
    """References to `bufs[i]`, counted the same way for the probe below and for the pool."""
    return sys.getrefcount(bufs[i])


#: What `_count` says of a buffer only the pool's list holds, measured rather than assumed (interpreters
#: differ in the temporary references they count).
_ALONE = _count([np.empty(0, np.uint8)], 0) if _EXACT_REFCOUNTS else 0


class BufferPool:
    """Up to `keep` reusable byte buffers of `nbytes` each (`take()`); see the module docstring."""

    def __init__(self, nbytes: int, keep: int = 4):
        self.nbytes, self.keep = int(nbytes), int(keep)
        self._bufs: list[np.ndarray] = []
        self._lock = threading.Lock()
        self.enabled = _EXACT_REFCOUNTS and self.nbytes >= MIN_POOLED_BYTES

    def take(self) -> np.ndarray:
        """A uint8 buffer of `nbytes` that nothing else references (its contents are left over: overwrite it)."""
        if not self.enabled:
            return np.empty(self.nbytes, np.uint8)
        with self._lock:
            bufs = self._bufs
            for i in range(len(bufs)):
                if _count(bufs, i) <= _ALONE:
                    return bufs[i]
            buf = np.empty(self.nbytes, np.uint8)
            if len(self._bufs) < self.keep:
                self._bufs.append(buf)
            return buf


__all__ = ["BufferPool", "MIN_POOLED_BYTES"]
