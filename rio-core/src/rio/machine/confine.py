"""Names read from files that people download and share (a dataset's `dataset.json` and `episode.json`, a
station file, a calibration) become paths only through `inside`, which refuses one that leaves its root.

Why one helper: such a name is data, not a path the user typed. `"dir": "../../home/me/.ssh"` in a
downloaded dataset's index, a `files` key of `"../../x"` or a video symlinked to `/etc/shadow` would
otherwise make `rio datasets info` hash, `rio export` read, and `rio datasets merge` or repair write files
anywhere the user can. The check resolves symlinks (`os.path.realpath`) on both sides, so a link inside
the root that points out is refused like `..` is; a path that does not exist yet (what a writer is about
to create) is resolved as far as it exists. Every reader and writer of those files calls it, so the rule
is the same everywhere and a violation is one line naming the file and the field.
"""

from __future__ import annotations

import os
from pathlib import Path

from rio.errors import ConfigError


class OutsideRoot(ConfigError):
    """A name read from a file points outside the directory it must stay in."""


def inside(root: str | os.PathLike[str], name: object, *, source: str | os.PathLike[str], field: str) -> Path:
    """`root / name`, refused (OutsideRoot naming `source` and `field`) unless it stays strictly inside
    `root` once every symlink is resolved. `name` is what the file said: a relative path, usually one
    file name; anything else (absolute, empty, not a string, a NUL byte) is refused too."""
    where = f"{source}: {field}"
    if not isinstance(name, str) or not name or "\x00" in name:
        raise OutsideRoot(f"{where}: {name!r} is not a file name")
    if os.path.isabs(name):
        raise OutsideRoot(f"{where}: {name!r} is an absolute path (it must name something inside {root})")
    path = Path(root) / name
    real_root = os.path.realpath(root)
    real = os.path.realpath(path)
    if real == real_root or os.path.commonpath([real_root, real]) != real_root:
        raise OutsideRoot(f"{where}: {name!r} points outside {root} (to {real})")
    return path


def is_inside(path: str | os.PathLike[str], root: str | os.PathLike[str]) -> bool:
    """Whether `path` is `root` or lies under it, symlinks resolved (an output inside the dataset it is
    made from, say)."""
    real_root, real = os.path.realpath(root), os.path.realpath(path)
    return os.path.commonpath([real_root, real]) == real_root
