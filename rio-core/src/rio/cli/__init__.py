"""The `rio` command line (typer + rich).

Built-in commands: `plugins list`, `drivers list`, `stations list|check`, `doctor`, `new plugin`,
`bench middleware`, `ports`, `find-port`, ...; plugins add their own through the `rio_cli` hook.
Commands import only what they need, inside the command, so `rio plugins list` stays fast. What every
command shares (`--json`, one error line, `rio --debug`, shell completion): docs/cli.md.
"""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `rio` script; returns the exit status (rio.cli.app.RioGroup says which)."""
    from rio.cli.app import run

    return run(sys.argv[1:] if argv is None else argv)
