"""Cheap descriptions of what a plugin provides. Listing specs imports no vendor SDK:
`target` is an import path resolved only when a station actually uses the component.

A spec is checked when its plugin's hook is called (`check_spec`), so a malformed one is reported
with the plugin's name and skipped instead of failing later inside a station.
"""

from __future__ import annotations

import importlib
import os
import re
from dataclasses import dataclass, field
from typing import Any

DRIVER_KINDS = ("arm", "gripper", "hand", "humanoid", "camera", "teleop", "sensor", "base")
KINDS = (
    *DRIVER_KINDS, "policy",
    "middleware", "dataset_format", "embodiment", "station", "command", "workflow",
)

#: Which kinds each spec-returning hook may register.
HOOK_KINDS: dict[str, tuple[str, ...]] = {
    "rio_middlewares": ("middleware",),
    "rio_drivers": DRIVER_KINDS,
    "rio_policies": ("policy",),
    "rio_dataset_formats": ("dataset_format",),
    "rio_embodiments": ("embodiment",),
    "rio_stations": ("station",),
    "rio_workflows": ("workflow",),
}

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$")
_IMPORT_PATH = re.compile(r"^[A-Za-z_][\w.]*(:[A-Za-z_][\w.]*)?$")


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
    #: 'module:attr' of the class; for kind 'station', a .toml path or 'package:resource/path.toml'.
    target: str
    description: str = ""
    #: Config values this name fixes: a model variant is the same class with a preset
    #: (`Spec("so101.follower", "arm", ".../driver:So100Follower", preset={"model": "so101"})`).
    preset: dict[str, Any] = field(default_factory=dict, hash=False)
    #: Names this spec had before a rename (stations: `rio.station.load.find_station` still loads it by
    #: them, with a notice, for one release; `rio stations list` shows them).
    formerly: tuple[str, ...] = ()
    #: Filled in by the loader: the distribution that registered this spec.
    plugin: str = field(default="", compare=False)

    def load(self) -> Any:
        return import_path(self.target)

    def config_model(self) -> Any:
        """The component class's `Config` (imports the class module: keep vendor SDK imports out of it)."""
        return getattr(self.load(), "Config", None)

    def validate(self, fields: dict[str, Any]) -> Any:
        """The component's validated config for station `fields` over this spec's preset. Raises
        pydantic's ValidationError, or ValueError for a field that contradicts the preset."""
        from rio.config import apply_preset

        return self.config_model().model_validate(apply_preset(self.preset, fields, self.name))


def check_spec(spec: Any, allowed_kinds: tuple[str, ...]) -> str | None:
    """Why `spec` is unusable (one line), or None. Never imports the target."""
    if not isinstance(spec, Spec):
        return f"returned {type(spec).__name__} {spec!r:.60}, not a rio.plugins.specs.Spec"
    if not isinstance(spec.name, str) or not _NAME.match(spec.name):
        return f"spec name {spec.name!r} is not a valid name (letters, digits, '.', '_', '-')"
    if spec.kind not in allowed_kinds:
        return f"{spec.kind!r} spec '{spec.name}' is not allowed here (expected kind in {list(allowed_kinds)})"
    if not isinstance(spec.target, str) or not spec.target:
        return f"spec '{spec.name}' has no target"
    if spec.kind == "station":
        pkg, sep, res = spec.target.partition(":")
        if not (os.path.isabs(spec.target) or (sep and _IMPORT_PATH.match(pkg) and res)):
            return (f"station '{spec.name}' target {spec.target!r} is neither an absolute path nor a "
                    "package resource like 'package:stations/name.toml'")
    elif not _IMPORT_PATH.match(spec.target):
        return f"spec '{spec.name}' target {spec.target!r} is not an import path like 'package.module:Class'"
    if not isinstance(spec.preset, dict) or not all(isinstance(k, str) for k in spec.preset):
        return f"spec '{spec.name}' preset must be a dict of config field values, got {spec.preset!r:.60}"
    if not isinstance(spec.description, str):
        return f"spec '{spec.name}' description must be a string"
    if not isinstance(spec.formerly, tuple):
        return f"spec '{spec.name}' formerly must be a tuple of old names, got {spec.formerly!r:.60}"
    for old in spec.formerly:
        if not isinstance(old, str) or not _NAME.match(old):
            return (f"spec '{spec.name}' formerly: {old!r:.60} is not a valid name "
                    "(letters, digits, '.', '_', '-')")
        if old == spec.name:
            return f"spec '{spec.name}' formerly: '{old}' is its current name"
    return None
