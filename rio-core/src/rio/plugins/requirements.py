"""What a plugin needs from the machine, declared through the `rio_requirements` hook and shown by `rio doctor`.

A plugin knows which optional modules and system setup its components need; the core does not. So each
plugin declares them as `Requirement`s and `rio doctor` only evaluates them. Evaluating is safe on a
broken machine: a module is located with `importlib.util.find_spec` (never imported, so a slow or
crashing vendor SDK is not run just to be listed), and a check that raises is reported, not propagated.

What no wheel can bring (a shared library or a program from a Debian package) is a
`rio.machine.system_needs.SystemNeed`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

_MODULE = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")
_CHECK = re.compile(r"^[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*$")


@dataclass(frozen=True)
class Requirement:
    """One thing a plugin needs. `module` is an import name (None for a pure system check); `install`
    is the exact command a user types to get it; `purpose` says in one line what needs it.

    `check`, optional, is 'package.module:function' of a zero-argument function that returns None when
    all is well or a one-line problem ("no permission on /dev/ttyACM0: ..."). It is imported and run by
    `rio doctor` only, and only once `module` (if any) is present, so it may import that module."""

    module: str | None
    install: str = ""
    purpose: str = ""
    check: str | None = None


def check_requirement(req: Any) -> str | None:
    """Why `req` is unusable (one line), or None. Imports nothing."""
    if not isinstance(req, Requirement):
        return f"returned {type(req).__name__} {req!r:.60}, not a rio.plugins.requirements.Requirement"
    if req.module is None and req.check is None:
        return "a requirement needs a module, a check, or both"
    if req.module is not None and not (isinstance(req.module, str) and _MODULE.match(req.module)):
        return f"requirement module {req.module!r} is not an import name like 'package.module'"
    if req.check is not None and not (isinstance(req.check, str) and _CHECK.match(req.check)):
        return f"requirement check {req.check!r} is not an import path like 'package.module:function'"
    if not isinstance(req.install, str) or not isinstance(req.purpose, str):
        return f"requirement {req.module or req.check!r}: install and purpose must be strings"
    return None


def module_present(module: str) -> bool:
    """Whether `module` can be imported, without importing it (only its parent packages are imported)."""
    import importlib.util

    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a parent package is missing or broken
        return False


def run_check(target: str) -> str | None:
    """Import and call a check; None when it passes, else its problem, or why the check itself failed."""
    from rio.plugins.specs import import_path

    try:
        result = import_path(target)()
    except (Exception, SystemExit) as e:  # a broken check is a finding, never a crash of `rio doctor`
        return f"check {target} failed: {type(e).__name__}: {e}"
    if result is None or isinstance(result, str):
        return result
    return f"check {target} returned {type(result).__name__}, not None or a problem string"


def serial_port_problem() -> str | None:
    """A ready-made check for plugins on USB serial adapters (`check="rio.plugins.requirements:serial_port_problem"`):
    adapters that exist but that this user may not open (on Linux they belong to a group such as dialout
    or uucp). No adapter at all is fine: the device may be unplugged."""
    import glob
    import os

    ports = sorted(glob.glob("/dev/ttyACM*") + glob.glob("/dev/ttyUSB*"))
    denied = [p for p in ports if not os.access(p, os.R_OK | os.W_OK)]
    if not denied:
        return None
    try:
        import grp

        group = grp.getgrgid(os.stat(denied[0]).st_gid).gr_name
    except (ImportError, KeyError, OSError):
        group = "dialout"
    return f"no permission on {', '.join(denied)}: sudo usermod -aG {group} $USER, then log in again"


@dataclass(frozen=True)
class Status:
    """A requirement as found on this machine. `present` is None when there is no module to look for;
    `problem` is the check's finding (None when it passed, or did not run because the module is missing)."""

    requirement: Requirement
    present: bool | None
    checked: bool
    problem: str | None

    @property
    def ok(self) -> bool:
        return self.present is not False and self.problem is None

    def as_dict(self) -> dict[str, Any]:
        r = self.requirement
        return {"module": r.module, "purpose": r.purpose, "present": self.present, "install": r.install,
                "check": r.check, "checked": self.checked, "problem": self.problem, "ok": self.ok}


def evaluate(req: Requirement) -> Status:
    """Look for the module, then run the check if there is one and the module is there."""
    present = None if req.module is None else module_present(req.module)
    check = req.check if present is not False else None
    return Status(req, present, check is not None, None if check is None else run_check(check))
