"""The file the HDF5 exporter writes through: an I/O error never reaches the HDF5 library.

Why: when a write fails inside HDF5 (a full disk: ENOSPC), h5py raises, and closing the file afterwards
tries to flush HDF5's metadata to the same full disk; on a full tmpfs that ended in a segmentation fault
(`rio export ... -f hdf5`: exit 139 after "No space left on device"), a crash no `except` can catch and
that left the partial file behind. So h5py is given this object instead of a path (its `fileobj` driver):
every byte goes through `pwrite` here, and the first error is *kept*, not raised. From then on nothing
more is written to disk; what HDF5 still writes is held in memory (a few patches, to read back), so HDF5
finishes and closes normally. The exporter calls `check()` after each dataset it writes and once the file
is closed: the kept error is then raised from Python, as one `ExportError` line, and `export_dataset`
removes the partial output.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from .common import ExportError


class GuardedFile:
    """A new file at `path` (refused if it exists) with the methods h5py's fileobj driver calls."""

    def __init__(self, path: str | os.PathLike[str]):
        self.path = Path(path)
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
        self.pos = 0
        self.size = 0
        self.error: OSError | None = None
        #: (offset, bytes) written after the error, in order: held here, never on disk
        self.patches: list[tuple[int, bytes]] = []

    # -- what h5py calls -----------------------------------------------------------------------------
    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self.pos, os.SEEK_END: self.size}[whence]
        self.pos = base + offset
        return self.pos

    def tell(self) -> int:
        return self.pos

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data).cast("B")
        n = len(view)
        if self.error is None:
            try:
                done = 0
                while done < n:
                    done += os.pwrite(self.fd, view[done:], self.pos + done)
            except OSError as e:
                self.error = e
        if self.error is not None:
            self.patches.append((self.pos, bytes(view)))
        self.pos += n
        self.size = max(self.size, self.pos)
        return n

    def readinto(self, buf: bytearray | memoryview) -> int:
        out = memoryview(buf).cast("B")
        n = max(0, min(len(out), self.size - self.pos))
        data = bytearray(os.pread(self.fd, n, self.pos)) if n else bytearray()
        data.extend(bytes(n - len(data)))  # past what reached the disk: zeros, then the patches
        for offset, patch in self.patches:
            lo, hi = max(offset, self.pos), min(offset + len(patch), self.pos + n)
            if lo < hi:
                data[lo - self.pos:hi - self.pos] = patch[lo - offset:hi - offset]
        out[:n] = data
        self.pos += n
        return n

    def read(self, size: int = -1) -> bytes:
        buf = bytearray(max(0, self.size - self.pos) if size is None or size < 0 else size)
        n = self.readinto(buf)
        return bytes(buf[:n])

    def truncate(self, size: int | None = None) -> int:
        size = self.pos if size is None else size
        if self.error is None:
            try:
                os.ftruncate(self.fd, size)
            except OSError as e:
                self.error = e
        self.size = size
        return size

    def flush(self) -> None:
        """Nothing is buffered here: every write went to `pwrite` (or, after an error, to memory)."""

    # -- what the exporter calls ---------------------------------------------------------------------
    def check(self) -> None:
        """Raise the kept I/O error, if any, as one ExportError line (outside HDF5)."""
        if self.error is not None:
            e = self.error
            name = errno.errorcode.get(e.errno or 0, "")
            raise ExportError(f"{self.path}: {e.strerror or e}{f' [{name}]' if name else ''} while writing the "
                              "HDF5 file; the export stopped")

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
        self.patches.clear()
