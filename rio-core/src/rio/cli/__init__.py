"""The `rio` command line (typer + rich).

Built-in commands: `plugins list`, `drivers list`, `stations list|check`, `doctor`, `new plugin`,
`bench middleware`; plugins add their own through the `rio_cli` hook. Commands import only what
they need, inside the command, so `rio plugins list` stays fast.
"""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `rio` script. A RioError (bad station, unknown name, ...) is printed as one
    clear message with exit status 1, never as a traceback."""
    from ..errors import RioError
    from .app import build_app
    from .output import error

    app = build_app()
    try:
        app(args=sys.argv[1:] if argv is None else list(argv), prog_name="rio", standalone_mode=True)
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    except RioError as e:
        error(str(e))
        return 1
    return 0
