"""The installer commands behind `rio plugins install|uninstall`, and picking up a fresh install.

Like `llm install`, plugins go into the environment `rio` itself runs in (`sys.executable`): with
`uv pip ... --python <that python>` when uv is on PATH, otherwise with `<that python> -m pip`. These
command builders only build the argument list, so they are unit-tested without installing anything;
`activate_new_paths` then makes a fresh install importable in the running process.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence

from rio.plugins.known import normalize

CORE = "rio-core"


def install_command(specs: Sequence[str], editable: bool = False, upgrade: bool = False, *,
                    python: str, uv_path: str | None) -> list[str]:
    """The command installing `specs` (requirements, paths, URLs) into the environment of `python`.
    `editable` installs every spec as `-e SPEC` (local project paths); `upgrade` upgrades them."""
    if not specs:
        raise ValueError("nothing to install: give at least one requirement or path")
    if uv_path:
        cmd = [uv_path, "pip", "install", "--python", python]
    else:
        cmd = [python, "-m", "pip", "install"]
    if upgrade:
        cmd.append("--upgrade")
    for spec in specs:
        cmd += ["-e", spec] if editable else [spec]
    return cmd


def uninstall_command(names: Sequence[str], *, python: str, uv_path: str | None) -> list[str]:
    """The command removing distributions `names` from the environment of `python`. pip is passed
    `-y`: `rio plugins uninstall` asks for confirmation itself."""
    if not names:
        raise ValueError("nothing to uninstall: give at least one distribution name")
    if uv_path:
        return [uv_path, "pip", "uninstall", "--python", python, *names]
    return [python, "-m", "pip", "uninstall", "-y", *names]


def protected(names: Sequence[str]) -> list[str]:
    """The names in `names` that must never be uninstalled by `rio plugins uninstall` (rio-core)."""
    return [n for n in names if normalize(n) == CORE]


# -- after installing, in the running process -------------------------------------------------------
def _site_dirs() -> list[str]:
    import site

    dirs = list(getattr(site, "getsitepackages", list)())
    if site.ENABLE_USER_SITE:
        dirs.append(site.getusersitepackages())
    return [d for d in dirs if os.path.isdir(d)]


def pth_files() -> set[str]:
    """The `.pth` files of this environment's site directories (to tell which ones an install added)."""
    return {os.path.join(d, n) for d in _site_dirs() for n in os.listdir(d) if n.endswith(".pth")}


def activate_new_paths(before: set[str]) -> None:
    """Make what was just installed importable in this process, as the next interpreter start would:
    an editable install puts its source folder on sys.path through a `.pth` file, which Python reads
    only at start-up. Path lines of every `.pth` file are added if missing; `import` lines (editable
    finders) run only for files that are new since `before`."""
    import importlib

    for pth in sorted(pth_files()):
        try:
            with open(pth, encoding="utf-8") as f:
                lines = f.read().splitlines()
        except (OSError, UnicodeDecodeError):
            continue
        for line in lines:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            if line.startswith(("import ", "import\t")):
                if pth not in before:
                    try:
                        exec(line)  # what site.py does with such a line at start-up
                    except Exception:  # a broken .pth must not break `rio`; the listing shows the plugin's problem
                        pass
                continue
            path = os.path.abspath(os.path.join(os.path.dirname(pth), line))
            if os.path.isdir(path) and path not in sys.path:
                sys.path.append(path)
    importlib.invalidate_caches()


def uv_project_of(prefix: str) -> str | None:
    """The uv project directory owning the environment at `prefix` (`<project>/.venv` with a
    `uv.lock` beside it), else None: there a plain `uv sync` removes what `uv pip install` added."""
    parent = os.path.dirname(os.path.abspath(prefix))
    return parent if os.path.isfile(os.path.join(parent, "uv.lock")) else None
