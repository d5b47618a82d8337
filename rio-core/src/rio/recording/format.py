"""Dataset formats: the interface a `rio_dataset_formats` plugin implements, and the lookup.

A format is registered as a Spec of kind 'dataset_format' whose target is a `DatasetFormat` subclass;
its `Config` holds its options (`rio export ... -o key=value` is validated against it). Export reads a
native `Dataset`; import writes a native dataset with a `Recorder`, so imported data gets the same
crash-safe layout and checks as recorded data.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from ..config import Config, Configurable
from .dataset import Dataset

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
    from ..config import error_lines
    from ..errors import ConfigError
    from ..plugins import get_registry

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
