"""Dataset formats: the interface a `rio_dataset_formats` plugin implements, and the lookup.

A format is registered as a Spec of kind 'dataset_format' whose target is a `DatasetFormat` subclass;
its `Config` holds its options (`rio export ... -o key=value` is validated against it). Export reads a
native `Dataset`; import writes a native dataset with a `Recorder`, so imported data gets the same
crash-safe layout and checks as recorded data.

`export_dataset` is the one way to export: it verifies the chosen episodes first (a damaged one is
refused before anything is written, unless the dataset was opened with `allow_damaged`), and a failed
export removes what it had written, so a partial output never passes for a finished one.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from rio.config import Config, Configurable
from rio.recording.dataset import Dataset

#: progress(done, total, what): called as work advances (the CLI draws a rich progress bar from it)
Progress = Callable[[int, int, str], None]


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
                   progress: Progress | None = None) -> dict[str, Any]:
    """`fmt.export` after verifying the episodes it will read; if it fails, whatever it created at
    `out` is removed (what was there before is left alone)."""
    out = Path(out)
    chosen = episodes if episodes is not None else [e["index"] for e in dataset.episodes]
    for k in chosen:
        dataset.episode(k).check()
    before = _entries(out)
    try:
        return fmt.export(dataset, out, episodes=episodes, progress=progress)
    except BaseException:
        _remove_new(out, before)
        raise


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
