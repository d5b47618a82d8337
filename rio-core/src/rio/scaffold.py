"""`rio new plugin`: render the plugin template shipped in `rio/templates/plugin` with copier.

The template is a copier project (package data of rio-core), so what a generated plugin contains is
readable and testable as files, not assembled from strings. copier is an optional dependency:
`pip install 'rio-core[new]'` (included in `rio-core[all]`).
"""

from __future__ import annotations

import re
from pathlib import Path

from .errors import ConfigError, RioError

PLUGIN_KINDS = ("arm", "gripper", "camera", "teleop", "policy")
_NAME = re.compile(r"^[a-z][a-z0-9_-]*[a-z0-9]$")


def template_dir() -> Path:
    return Path(__file__).parent / "templates" / "plugin"


def check_name(name: str) -> str:
    if not _NAME.match(name):
        raise ConfigError(f"plugin name '{name}' must be lowercase letters, digits, '-' or '_', "
                          "start with a letter and be at least 2 characters (e.g. 'acme')")
    if name in {"core", "rio"}:
        raise ConfigError(f"plugin name '{name}' is reserved")
    return name


def new_plugin(name: str, kind: str = "arm", output: str | Path = ".", *, force: bool = False) -> Path:
    """Generate `<output>/rio-<name>/`; returns its path."""
    from .suggest import unknown

    check_name(name)
    if kind not in PLUGIN_KINDS:
        raise ConfigError(unknown("plugin kind", kind, PLUGIN_KINDS))
    try:
        import copier
    except ImportError:
        raise RioError("`rio new` needs copier, which is not installed: pip install 'rio-core[new]'") from None
    dst = Path(output) / f"rio-{name}"
    if dst.exists() and any(dst.iterdir()) and not force:
        raise RioError(f"{dst} already exists and is not empty (use --force to render into it)")
    copier.run_copy(str(template_dir()), str(dst), data={"name": name, "kind": kind}, defaults=True,
                    overwrite=force, quiet=True, unsafe=False)
    return dst
