"""Printing for the CLI: rich tables for people, `--json` for scripts, warnings and errors on stderr."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterable, Sequence
from typing import Any


def console(stderr: bool = False):
    from rich.console import Console

    return Console(stderr=stderr, highlight=False, soft_wrap=False)


def table(title: str | None, columns: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    from rich.markup import escape
    from rich.table import Table

    t = Table(title=escape(title) if title else None, title_justify="left", header_style="bold")
    for c in columns:
        t.add_column(c, overflow="fold")
    for r in rows:
        # plain values are shown literally; rich renderables (e.g. a styled Text) as they are
        t.add_row(*(x if hasattr(x, "__rich_console__") else escape(str(x)) for x in r))
    console().print(t)


def print_json(obj: Any) -> None:
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=False) + "\n")


def warn(message: str) -> None:
    console(stderr=True).print(f"[yellow]warning:[/] {message}", soft_wrap=True)


def error(message: str) -> None:
    from rich.markup import escape

    # soft_wrap: a long path or list stays on one line, so it can be copied and grepped
    console(stderr=True).print(f"[bold red]error:[/] {escape(message)}", soft_wrap=True)


def warn_problems(registry: Any) -> None:
    """Report every skipped plugin (or part of one) by name, on stderr."""
    from rich.markup import escape

    for p in registry.problems:
        warn(escape(str(p)))
