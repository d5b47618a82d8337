"""Camera frames handed from the control loop to the encoder process without pickling.

A ring of fixed-size slots in anonymous shared memory (a memfd on Linux, an unlinked temporary
file elsewhere): the memory vanishes when the last process holding it exits, so a SIGKILL leaves
nothing in /dev/shm. The recorder copies a frame into the next free slot (one memcpy, straight from
the camera's own ring where the frame still is: `rio.schema.RingCamera.in_place`) and sends only the
slot number; the encoder answers "released" when done with a slot. The writer never waits:
when every slot is taken (the encoder fell seconds behind) the frame is dropped and counted.

Memory order: both hand-overs go through the socket between the two processes, never through a
counter in the shared memory. A message through the kernel is ordered on every CPU (the sender's
writes before it are visible to the receiver after it), so the encoder never sees a half-written
frame and the recorder never overwrites a slot the encoder is still reading, on ARM as on x86.
"""

from __future__ import annotations

import mmap
import os

import numpy as np

from rio.machine import host


class FrameRing:
    def __init__(self, shape: tuple[int, ...], dtype: str, slots: int, fd: int | None = None):
        self.shape, self.dtype, self.slots = tuple(shape), np.dtype(dtype), int(slots)
        self.frame_bytes = int(np.prod(self.shape)) * self.dtype.itemsize
        size = self.slots * self.frame_bytes
        self.fd = host.anonymous_memory("rio-frames", size) if fd is None else fd
        self.mm = mmap.mmap(self.fd, size)
        self._data = np.ndarray((self.slots, *self.shape), self.dtype, buffer=self.mm, offset=0)
        #: writer side: frames put, and frames the encoder said it released
        self.produced = self.consumed = 0

    def backlog(self) -> int:
        return self.produced - self.consumed

    # -- writer side (recorder) ---------------------------------------------------------------------
    def try_put(self, frame: np.ndarray) -> int | None:
        """Copy `frame` into a free slot; its slot number, or None when the ring is full."""
        slot = self.reserve()
        if slot is None:
            return None
        np.copyto(self._data[slot], frame, casting="same_kind")
        self.commit()
        return slot

    def reserve(self) -> int | None:
        """The next free slot, to be filled (`view`) and then `commit`ted, or None when the ring is full.
        Until committed it is not handed over: a frame found torn while it was copied in is simply not
        committed, and the slot is filled again by the next one."""
        n = self.produced
        return None if n - self.consumed >= self.slots else n % self.slots

    def commit(self) -> None:
        """The reserved slot is filled: it counts as produced (the encoder may be told about it)."""
        self.produced += 1

    def released(self) -> None:
        """The encoder is done with the oldest slot in use (its "released" message arrived)."""
        self.consumed += 1

    # -- both sides ---------------------------------------------------------------------------------
    def view(self, slot: int) -> np.ndarray:
        """Slot `slot` in place: the writer fills a reserved one, the encoder reads a handed-over one."""
        return self._data[slot]

    def close(self) -> None:
        self._data = None  # drop buffer exports before closing the map
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
