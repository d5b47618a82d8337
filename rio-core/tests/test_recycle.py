"""Recycled copy buffers: a buffer comes back only when nothing made from it is alive, so a sample a
reader keeps never changes under it."""

from __future__ import annotations

import numpy as np

from rio.runtime.buffers import RingBuffer
from rio.runtime.layout import Layout
from rio.runtime.recycle import MIN_POOLED_BYTES, BufferPool


def test_a_buffer_is_reused_only_once_nothing_holds_it():
    pool = BufferPool(MIN_POOLED_BYTES, keep=2)
    a = pool.take()
    addr = a.ctypes.data
    view = a[10:20].view(np.uint16)
    del a
    b = pool.take()  # `a` is still reachable through `view`
    assert b.ctypes.data != addr
    del view
    mem = memoryview(b)
    c = pool.take()
    assert c.ctypes.data == addr  # `a`'s buffer is free again
    assert pool.take().ctypes.data not in (addr, b.ctypes.data)  # both held: a new one
    del mem, b, c


def test_small_records_are_not_pooled():
    assert not BufferPool(MIN_POOLED_BYTES - 1).enabled


def test_samples_kept_by_a_reader_never_change():
    ring = RingBuffer(Layout({"rgb": np.zeros((120, 160, 3), np.uint8)}, owner="cam"), capacity=4)
    kept = []
    for i in range(12):
        ring.put({"rgb": np.full((120, 160, 3), i, np.uint8)})
        kept.append(ring.get())  # each a checked copy, held while later ones are read
        ring.get()  # and one dropped at once, whose buffer is reused
    for i, s in enumerate(kept):
        assert (s["rgb"] == i).all()
