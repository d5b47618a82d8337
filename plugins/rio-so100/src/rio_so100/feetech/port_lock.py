"""One transaction at a time on a serial bus shared by several nodes.

The SO-100's jaw servo sits on the arm's bus but is driven by its own gripper node (possibly in
another process), so both open the same port. Each transaction (instruction out, status packets in)
holds an exclusive lock (`rio.machine.host.FileLock`: flock on Linux and macOS) on a lock file named after
the port's real path; the tty's input queue is shared, so the holder also drops stale input before
it speaks. (Windows opens a COM port for one process only, so there both nodes must share one process.)
"""

from __future__ import annotations

import os
import tempfile

from rio.machine import host


def lock_dir() -> str:
    base = os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir()
    path = os.path.join(base, f"rio-so100-{getattr(os, 'getuid', lambda: 0)()}")
    os.makedirs(path, mode=0o700, exist_ok=True)
    return path


class PortLock:
    def __init__(self, port: str):
        real = os.path.realpath(port)
        name = real.strip("/").replace("/", "_") or "port"
        self.path = os.path.join(lock_dir(), f"{name}.lock")
        self._fd: int | None = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
        self._lock = host.FileLock(self._fd)

    def __enter__(self) -> PortLock:
        self._lock.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self._lock.__exit__(*exc)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
