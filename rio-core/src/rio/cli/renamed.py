"""A command renamed in a release keeps its old name for one more release: hidden from the help, it runs
the same function after one line on stderr naming the new command (what `Config.renamed` does for a
station field, and `Spec.formerly` for a station)."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import typer


def keep_old_name(app: typer.Typer, old: str, new: str, command: Callable[..., Any]) -> None:
    """Register `command` (registered as `new`) on `app` also as `old`, hidden, with a notice."""

    @functools.wraps(command)
    def old_name(*args: Any, **kwargs: Any) -> Any:
        typer.echo(f"'{old}' is now '{new}' (the old name works until the next release)", err=True)
        return command(*args, **kwargs)

    app.command(old, hidden=True)(old_name)
