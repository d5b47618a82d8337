"""Where drivers keep per-device files (calibrations, certificates), one place for every plugin.

`$XDG_CONFIG_HOME/rio/` (default `~/.config/rio/`): calibrations under `calibration/<kind>/<name>.json`
(`kind` names the device family and role: `so101-leader`, `gello-xarm7`), so a station file says
`calibration = "left"` and the driver finds the file. A name that looks like a path (has '/' or ends
in .json) is used as given. Files are written whole or not at all: a crash mid-save never leaves a
half-written calibration that would move a servo wrongly.

A name is data (a station file someone shared says it): its file must stay in that folder, symlinks
resolved (`rio.machine.confine`). A path is what the user chose and is used as given."""

from __future__ import annotations

import os
from pathlib import Path

from rio.machine.confine import inside


def config_home() -> Path:
    base = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
    return Path(base) / "rio"


def calibration_path(name: str, kind: str) -> Path:
    """A calibration name -> its file, which stays in the calibration folder of `kind` (`confine.inside`:
    a name from a shared station file must not reach elsewhere through a symlink); a path as given."""
    if name.endswith(".json") or "/" in name:
        return Path(name).expanduser()
    folder = config_home() / "calibration" / kind
    return inside(folder, f"{name}.json", source=f"calibration '{name}'", field=f"its file in {folder}")


def save_text(path: Path, text: str) -> Path:
    """Write `text` to `path` atomically (a temporary file renamed over it), creating its directory."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
    return path
