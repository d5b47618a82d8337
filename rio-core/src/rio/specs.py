"""Cheap descriptions of what a plugin provides. Listing specs imports no vendor SDK:
`target` is an import path resolved only when a station actually uses the component."""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any

KINDS = (
    "arm", "gripper", "hand", "humanoid", "camera", "teleop", "sensor", "policy",
    "middleware", "dataset_format", "embodiment", "station", "command",
)


def import_path(path: str) -> Any:
    """Resolve 'package.module:attr' (or 'package.module.attr')."""
    mod, sep, attr = path.partition(":")
    if not sep:
        mod, _, attr = path.rpartition(".")
    obj = importlib.import_module(mod)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


@dataclass(frozen=True)
class Spec:
    name: str
    kind: str
    target: str
    description: str = ""
    #: Pydantic model (class or import path) validating this component's station-file fields.
    config: Any = None
    #: Filled in by the loader: the distribution that registered this spec.
    plugin: str = field(default="", compare=False)

    def load(self) -> Any:
        return import_path(self.target)

    def load_config(self) -> Any:
        return import_path(self.config) if isinstance(self.config, str) else self.config
