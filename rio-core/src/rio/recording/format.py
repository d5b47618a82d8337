"""Dataset formats: the interface a `rio_dataset_formats` plugin implements, and the lookup.

A format is registered as a Spec of kind 'dataset_format' whose target is a `DatasetFormat` subclass;
its `Config` holds its options (`rio export ... -o key=value` is validated against it). Export reads a
native `Dataset`; import writes a native dataset with a `Recorder`, so imported data gets the same
crash-safe layout and checks as recorded data.

`export_dataset` is the one way to export: it verifies the chosen episodes first (a damaged one is
refused before anything is written, unless the dataset was opened with `allow_damaged`), refuses an
output inside the dataset it reads, checks free space before it starts and about once a second while it
runs (through the progress calls), and a failed export, whatever stopped it (a full disk, a permission,
Ctrl-C), removes what it had written, so a partial output never passes for a finished one. An I/O error
ends as one `ExportError` line saying what failed and that the partial output is gone.
"""

from __future__ import annotations

import errno
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from rio.config import Config, Configurable
from rio.machine.confine import is_inside
from rio.recording import paths as L
from rio.recording import recorder as R
from rio.recording.dataset import Dataset, DatasetError

#: progress(done, total, what): called as work advances (the CLI draws a rich progress bar from it)
Progress = Callable[[int, int, str], None]

#: Free space below which an export does not start, and stops (the recorder's margin).
MIN_FREE_BYTES = R.MIN_FREE_BYTES
#: Seconds between free-space checks while an export runs (at its progress calls).
_SPACE_EVERY_S = 1.0


class ExportError(DatasetError):
    """An export that cannot start or could not finish (its partial output is removed)."""


class DatasetFormat(Configurable):
    Config = Config
    name: ClassVar[str] = ""
    can_export: ClassVar[bool] = True
    can_import: ClassVar[bool] = False

    def export(self, dataset: Dataset, out: Path, *, episodes: list[int] | None = None,
               progress: Progress | None = None) -> dict[str, Any]:
        """Write `dataset` (or the given episode indices) to `out`; returns a short summary."""
        raise NotImplementedError(f"format '{self.name}' cannot export")

    def import_(self, src: Path, out: Path, *, progress: Progress | None = None) -> dict[str, Any]:
        """Read `src` in this format into a native dataset at `out`; returns a short summary."""
        raise NotImplementedError(f"format '{self.name}' cannot import")


def get_format(name: str, options: dict[str, Any] | None = None, registry: Any = None) -> DatasetFormat:
    """An instance of the registered format `name`, its options validated by the spec's model."""
    from rio.config import error_lines
    from rio.errors import ConfigError
    from rio.plugins import get_registry

    reg = registry or get_registry()
    spec = reg.find("rio_dataset_formats", name, "dataset format")
    cls = spec.load()
    from pydantic import ValidationError

    try:
        return cls(spec.validate(dict(options or {})))
    except ValidationError as e:
        raise ConfigError(f"dataset format '{name}' options:\n  "
                          + "\n  ".join(error_lines(e, "", cls.Config))) from None
    except ValueError as e:
        raise ConfigError(f"dataset format '{name}' options: {e}") from None


def export_dataset(fmt: DatasetFormat, dataset: Dataset, out: str | Path, *, episodes: list[int] | None = None,
                   progress: Progress | None = None, min_free_bytes: int = MIN_FREE_BYTES,
                   overwrite: bool = False) -> dict[str, Any]:
    """`fmt.export` after verifying the episodes it will read (see the module docstring); if it fails,
    whatever it created at `out` is removed (what was there before is left alone). `min_free_bytes`: the
    free space on `out`'s disk below which it does not start, and stops.

    An `out` that exists and is not empty (a directory with entries, a file) is refused unless `overwrite`;
    then it is moved aside first and deleted only once the new export has finished: a failed export puts
    it back. Never the dataset itself, a folder holding it, or another native dataset."""
    out = Path(out)
    if is_inside(out, dataset.root):
        raise ExportError(f"{out}: inside the dataset it would be exported from ({dataset.root}); "
                          "write the export somewhere else")
    occupied = _occupied(out)
    if occupied and not overwrite:
        raise ExportError(f"{out} exists and is not empty; --overwrite (overwrite=True) replaces it")
    if occupied and (is_inside(dataset.root, out) or (out / L.INDEX).exists()):
        raise ExportError(f"{out}: holds a RIO dataset{' (the one exported)' if is_inside(dataset.root, out) else ''}"
                          "; --overwrite replaces only exports: choose another output")
    chosen = episodes if episodes is not None else [e["index"] for e in dataset.episodes]
    for k in chosen:
        dataset.episode(k).check()
    _SpaceWatch(out, min_free_bytes).check("not starting the export")
    aside = _move_aside(out) if occupied else None
    try:
        result = _export(fmt, dataset, out, episodes, progress, _SpaceWatch(out, min_free_bytes))
    except BaseException:
        if aside is not None:
            _remove_new(out, None)
            aside.rename(out)
        raise
    if aside is not None:
        _remove_new(aside, None)
    return result


def _export(fmt: DatasetFormat, dataset: Dataset, out: Path, episodes: list[int] | None,
            progress: Progress | None, space: _SpaceWatch) -> dict[str, Any]:
    """`fmt.export` with free-space checks at its progress calls; a failure removes what it created."""
    before = _entries(out)

    def advance(done: int, total: int, what: str) -> None:
        space.check("export stopped", every_s=_SPACE_EVERY_S)
        if progress is not None:
            progress(done, total, what)

    try:
        return fmt.export(dataset, out, episodes=episodes, progress=advance)
    except BaseException as e:
        _remove_new(out, before)
        cause = _os_error(e)
        if cause is None or isinstance(e, DatasetError):
            raise
        what = errno.errorcode.get(cause.errno or 0, "")
        where = f" ({cause.filename})" if cause.filename else ""
        raise ExportError(f"{out}: the export failed: {cause.strerror or cause}{f' [{what}]' if what else ''}"
                          f"{where}; its partial output was removed") from None


class _SpaceWatch:
    """Free space on the disk an export writes to: `check` raises ExportError below `min_free` (at most once
    per `every_s` seconds it measures; `rio.recording.recorder.free_bytes`, which tests replace)."""

    def __init__(self, out: Path, min_free: int):
        self.out, self.min_free, self.t_last = out, int(min_free), -float("inf")
        self.where = next((p for p in (out, *out.parents) if p.exists()), Path("."))

    def check(self, doing: str, every_s: float = 0.0) -> None:
        now = time.monotonic()
        if now - self.t_last < every_s or self.min_free <= 0:
            return
        self.t_last = now
        free = R.free_bytes(self.where)
        if free < self.min_free:
            raise ExportError(f"{self.out}: {doing}: {free / 1e6:.1f} MB free on its disk, an export needs "
                              f"{self.min_free / 1e6:.0f} MB; free some space" +
                              ("; its partial output was removed" if doing != "not starting the export" else ""))


def _occupied(out: Path) -> bool:
    """Whether `out` holds something an export would have to replace (a file, or a non-empty directory)."""
    if out.is_symlink() or out.is_file():
        return True
    return out.is_dir() and any(out.iterdir())


def _move_aside(out: Path) -> Path:
    """Rename `out` to a hidden sibling (same disk: a rename, nothing copied) and return where it went."""
    for k in range(1000):
        aside = out.with_name(f".{out.name}.rio-replaced-{os.getpid()}-{k}")
        if not aside.exists() and not aside.is_symlink():
            out.rename(aside)
            return aside
    raise ExportError(f"{out}: cannot move it aside to replace it (too many .{out.name}.rio-replaced-* beside it)")


def _os_error(e: BaseException | None) -> OSError | None:
    """The OSError behind a failure (itself, or what it was raised from or during), None if none."""
    seen = 0
    while e is not None and seen < 16:
        if isinstance(e, OSError):
            return e
        e, seen = e.__cause__ or e.__context__, seen + 1
    return None


def _entries(out: Path) -> set[str] | None:
    """What `out` holds now: None if it does not exist, its entry names if it is a directory."""
    if not out.exists() and not out.is_symlink():
        return None
    return {p.name for p in out.iterdir()} if out.is_dir() and not out.is_symlink() else set()


def _remove_new(out: Path, before: set[str] | None) -> None:
    """Remove what an export created: `out` itself if it did not exist, else the entries it added."""
    if before is None:
        targets = [out] if out.exists() or out.is_symlink() else []
    elif out.is_dir() and not out.is_symlink():
        targets = [p for p in out.iterdir() if p.name not in before]
    else:
        targets = []
    for p in targets:
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
