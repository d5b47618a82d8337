"""Durability primitives: fsync files and directories, replace a JSON file atomically, read one
back (a damaged file is one error naming it), hash files, move something aside without deleting it.

A rename is atomic but not durable until the directory holding it is fsynced; a file's bytes are
not durable until the file is. Everything the recorder calls "finished" went through these.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import time
from pathlib import Path
from typing import Any

from rio.errors import ConfigError

#: os.write errors that mean "no space left" (a full disk, or the user's quota)
DISK_FULL_ERRNOS = (errno.ENOSPC, errno.EDQUOT)


def fsync_file(path: str | os.PathLike) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_dir(path: str | os.PathLike) -> None:
    """Make renames and new entries in directory `path` durable (a no-op where unsupported)."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_json_atomic(path: str | os.PathLike, obj: Any) -> None:
    """Replace `path` with `obj` as JSON: readers see the old file or the new one, never a mix."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    data = (json.dumps(obj, indent=1, sort_keys=False) + "\n").encode()
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        os.write(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)
    fsync_dir(path.parent)


def read_json(path: str | os.PathLike) -> Any:
    """A JSON file's contents. Anything that cannot be read as JSON (torn, zeroed, not UTF-8, nested too
    deeply, unreadable) is one ConfigError naming the file, so no dataset command ends in a traceback."""
    path = Path(path)
    try:
        return json.loads(path.read_bytes())
    except FileNotFoundError:
        raise ConfigError(f"{path}: missing") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot be read ({e.strerror or e})") from None
    except RecursionError:
        raise ConfigError(f"{path}: damaged (nested too deeply to be RIO metadata)") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: damaged (not UTF-8 text at byte {e.start})") from None
    except json.JSONDecodeError as e:
        raise ConfigError(f"{path}: damaged (not valid JSON: {e.msg} at line {e.lineno}, column {e.colno})") from None


def move_aside(path: Path, folder: Path, name: str | None = None) -> Path:
    """Move `path` into `folder` (created if needed) as `NAME-YYYYmmdd-HHMMSS[~k]`, a name no earlier
    move used, and make it durable. How the recorder discards and repair quarantines: never a delete."""
    folder.mkdir(exist_ok=True)
    base = f"{name or path.name}-{time.strftime('%Y%m%d-%H%M%S')}"
    dest, k = folder / base, 1
    while dest.exists():
        dest, k = folder / f"{base}~{k}", k + 1
    os.rename(path, dest)
    fsync_dir(path.parent)
    fsync_dir(folder)
    return dest


def sha256_file(path: str | os.PathLike, chunk: int = 1 << 20) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()


def describe_files(directory: Path, names: list[str]) -> dict[str, dict[str, Any]]:
    """{name: {bytes, sha256}}: lets `rio datasets info --verify` prove an episode is unchanged."""
    return {n: {"bytes": (directory / n).stat().st_size, "sha256": sha256_file(directory / n)} for n in names}


class AppendFile:
    """An append-only file written with one `os.write` per record: no user-space buffer, so a
    killed process loses nothing it had written (the kernel holds it), and a record is either
    wholly there or torn only at the very end (repair truncates to whole records)."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        self.bytes = 0

    def write(self, data: bytes | memoryview) -> None:
        view = memoryview(data)
        while view:
            n = os.write(self.fd, view)
            view = view[n:]
            self.bytes += n

    def close(self, sync: bool = True) -> None:
        if self.fd < 0:
            return
        try:
            if sync:
                os.fsync(self.fd)
        finally:
            os.close(self.fd)
            self.fd = -1
