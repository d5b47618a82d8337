"""A network server's memory goes back to the system once a flood is over.

A node bounds what it holds for its peers (the protocol's quotas), but the C allocator keeps what was freed:
glibc raises its mmap threshold to the size of the largest block freed (up to 32 MiB), so after one 4 MiB
message every later one is carved out of a heap that is never returned, and a node flooded with messages
under the size cap kept 1.5 GB after its peers had left. Two calls into glibc (nothing elsewhere):

- `release_large_buffers()`, when a server starts: blocks of `LARGE_BYTES` and more are always mapped on
  their own and unmapped when freed (a fixed threshold also stops the raising);
- `trim()`, when a flood has ended: the heaps' free memory is given back (`malloc_trim`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import threading
from typing import Any

log = logging.getLogger("rio.middleware.protocol")

#: Blocks at least this large are mapped on their own (a camera frame, 640x480x3, stays below it).
LARGE_BYTES = 1 << 20
_M_MMAP_THRESHOLD = -3  # glibc's mallopt parameter

_lock = threading.Lock()
_libc: Any = None
_done = False


def _glibc() -> Any:
    global _libc
    if _libc is None:
        try:
            lib = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
            _libc = lib if hasattr(lib, "mallopt") and hasattr(lib, "malloc_trim") else False
        except OSError:
            _libc = False
    return _libc


def release_large_buffers() -> bool:
    """Once per process: large blocks are unmapped when freed. False where the C library is not glibc."""
    global _done
    with _lock:
        if _done:
            return True
        libc = _glibc()
        if not libc:
            return False
        _done = bool(libc.mallopt(_M_MMAP_THRESHOLD, LARGE_BYTES))
        return _done


def trim() -> None:
    """Give the heaps' free memory back to the system (glibc; elsewhere nothing)."""
    libc = _glibc()
    if libc:
        libc.malloc_trim(0)
