"""Checks on command-line values, run by typer while it parses (`typer.Option(callback=...)`): a bad value
ends the command with one line naming the option before any station, process or file is touched.

Why callbacks and not `min=`: a range lets `nan` through (every comparison with it is false) and `inf`
past any minimum, and `--rate nan` or `--max-pos-speed -1` must not reach a control loop (unthrottled,
frozen or reversed arm). One helper per meaning, used by every command that takes such a value.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, TypeVar

import typer

N = TypeVar("N", int, float, None)
P = TypeVar("P", str, Path, None)


def _number(value: N, ok: bool, what: str) -> N:
    if value is not None and not (math.isfinite(value) and ok):
        raise typer.BadParameter(f"must be {what}, not {value}")
    return value


def positive(value: N) -> N:
    """A rate, speed, duration or interval: finite and > 0 (None: not given)."""
    return _number(value, value is not None and value > 0, "a finite number > 0")


def rate_hz(value: N) -> N:
    """A control or publishing rate: finite and within `rio.clock.RATE_RANGE_HZ` (the range a station's
    `rate_hz` has too). `--rate 1e-9` passed `positive` and made a first tick 10^9 s away, past any
    `--duration`."""
    from rio.clock import RATE_RANGE_HZ

    lo, hi = RATE_RANGE_HZ
    return _number(value, value is not None and lo <= value <= hi, f"a rate from {lo:g} to {hi:g} Hz")


def non_negative(value: N) -> N:
    """A length of time that may be zero (a cross-fade, an approach): finite and >= 0."""
    return _number(value, value is not None and value >= 0, "a finite number >= 0")


def fraction(value: N) -> N:
    """A share of something: finite, between 0 and 1."""
    return _number(value, value is not None and 0 <= value <= 1, "a number from 0 to 1")


def not_empty(value: P) -> P:
    """A name or path given as '' is always a mistake (an unset shell variable); say so at once."""
    if value is not None and not str(value).strip():
        raise typer.BadParameter("must not be empty")
    return value


def one_of(*choices: str):
    """A callback for a word from a fixed set (`--blend crossfade`): a typo is named at once, not when
    the run has started."""

    def check(value: str | None) -> str | None:
        if value is not None and value not in choices:
            raise typer.BadParameter(f"'{value}' is not one of {', '.join(choices)}")
        return value

    return check


def output_dir(value: P) -> P:
    """A directory to write into (a dataset to record into, a profile, an export): absent (created later)
    or a directory, never an existing file, and somewhere this user can create things (`writable_problem`),
    checked before the station starts rather than when the first file is written (`--record /proc/x` ended
    in a traceback after the run)."""
    not_empty(value)
    if value is not None and Path(value).exists() and not Path(value).is_dir():
        raise typer.BadParameter(f"'{value}' is a file, not a directory")
    if value is not None and (why := writable_problem(Path(value))):
        raise typer.BadParameter(f"'{value}' cannot be written: {why}")
    return value


def writable_problem(path: Path) -> str | None:
    """Why nothing can be created at or inside `path`, found by trying: a temporary directory is made (and
    removed at once) in `path` if it is a directory, else in its nearest existing parent, which must be a
    directory. None when that works. Permissions alone cannot tell (root passes every access check and
    still cannot write into /proc); trying can."""
    import tempfile

    where = next((p for p in (path, *path.parents) if p.exists()), Path("."))
    if not where.is_dir():
        return f"'{where}' is a file, not a directory"
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".rio-probe-", dir=where))
    except OSError as e:
        return f"{e.strerror or e} (in '{where}')"
    return None


def existing_dir(value: P) -> P:
    """A directory that must already exist (a plugin's folder)."""
    not_empty(value)
    if value is not None and not Path(value).is_dir():
        raise typer.BadParameter(f"'{value}' is not a directory" if Path(value).exists() else
                                 f"'{value}' does not exist")
    return value


def existing_path(value: P) -> P:
    """A file or directory to read (a dataset to import): it must exist."""
    not_empty(value)
    if value is not None and not Path(value).exists():
        raise typer.BadParameter(f"'{value}' does not exist")
    return value


def complete_station(incomplete: str) -> list[str]:
    """Shell completion of a station argument: the registered names that start with what was typed (a path
    is completed by the shell itself)."""
    try:
        from rio.plugins import get_registry

        names = sorted(s.name for s in get_registry().specs("rio_stations"))
    except Exception:  # completion must never print a traceback into the user's shell
        return []
    return [n for n in names if n.startswith(incomplete)]


def known_station(value: P) -> P:
    """A station name or .toml path that can be found (`rio stations list`), before anything opens."""
    not_empty(value)
    if value is not None:
        from rio.errors import RioError
        from rio.station.load import find_station

        try:
            find_station(str(value))
        except RioError as e:
            raise typer.BadParameter(str(e)) from None
    return value


def key_values(pairs: list[str] | None, option: str) -> dict[str, Any]:
    """Repeated `KEY=VALUE` options as a dict: JSON values (`3`, `true`, `[1, 2]`, `"x"`), a bare word
    is a string; a pair without `=` ends the command naming `option`."""
    out: dict[str, Any] = {}
    for p in pairs or []:
        key, sep, value = p.partition("=")
        if not sep or not key.strip():
            raise typer.BadParameter(f"'{p}': write key=value", param_hint=f"'{option}'")
        try:
            out[key.strip()] = json.loads(value)
        except ValueError:
            out[key.strip()] = value
    return out


def servo_port(value: P) -> P:
    """A serial bus's `--port`, with the station field's renamed values (`ServoBus.renamed_values`: the old
    "virtual" is "emulator" now) applied as a station file gets them, with the same one log line."""
    if value is None:
        return value
    from rio.config import accept_renamed
    from rio.interfaces.devices import ServoBus

    return accept_renamed(ServoBus, {"port": value})["port"]
