"""Camera frames handed from the control loop to the encoder process without pickling.

A ring of fixed-size slots in anonymous shared memory (a memfd on Linux, an unlinked temporary
file elsewhere): the memory vanishes when the last process holding it exits, so a SIGKILL leaves
nothing in /dev/shm. The recorder copies a frame into the next free slot (one memcpy) and sends
only the slot number; the encoder bumps `consumed` when done with a slot. The writer never waits:
when every slot is taken (the encoder fell seconds behind) the frame is dropped and counted.
"""

from __future__ import annotations

import mmap
import os
import tempfile

import numpy as np

_HEADER = 64  # produced (u64) at 0, consumed (u64) at 8


def _anonymous_fd(size: int) -> int:
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("rio-frames", 0)
    else:  # pragma: no cover - macOS
        fd, path = tempfile.mkstemp(prefix="rio-frames-")
        os.unlink(path)
    os.ftruncate(fd, size)
    return fd


class FrameRing:
    def __init__(self, shape: tuple[int, ...], dtype: str, slots: int, fd: int | None = None):
        self.shape, self.dtype, self.slots = tuple(shape), np.dtype(dtype), int(slots)
        self.frame_bytes = int(np.prod(self.shape)) * self.dtype.itemsize
        size = _HEADER + self.slots * self.frame_bytes
        self.fd = _anonymous_fd(size) if fd is None else fd
        self.mm = mmap.mmap(self.fd, size)
        self._ctr = np.ndarray((2,), np.uint64, buffer=self.mm, offset=0)
        self._data = np.ndarray((self.slots, *self.shape), self.dtype, buffer=self.mm, offset=_HEADER)

    @property
    def produced(self) -> int:
        return int(self._ctr[0])

    @property
    def consumed(self) -> int:
        return int(self._ctr[1])

    def backlog(self) -> int:
        return self.produced - self.consumed

    # -- writer side (recorder) ---------------------------------------------------------------------
    def try_put(self, frame: np.ndarray) -> int | None:
        """Copy `frame` into a free slot; its slot number, or None when the ring is full."""
        n = self.produced
        if n - self.consumed >= self.slots:
            return None
        slot = n % self.slots
        np.copyto(self._data[slot], frame, casting="same_kind")
        self._ctr[0] = n + 1
        return slot

    # -- reader side (encoder) ----------------------------------------------------------------------
    def view(self, slot: int) -> np.ndarray:
        return self._data[slot]

    def release(self) -> None:
        self._ctr[1] = self.consumed + 1

    def close(self) -> None:
        self._ctr = self._data = None  # drop buffer exports before closing the map
        try:
            self.mm.close()
        except BufferError:
            pass
        if self.fd >= 0:  # once: a second close of the number would close whatever reused it
            try:
                os.close(self.fd)
            except OSError:
                pass
            self.fd = -1
