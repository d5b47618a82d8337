"""The `rio` command line (typer + rich).

Built-in commands: `plugins list`, `drivers list`, `stations list|check`, `doctor`, `new plugin`,
`bench middleware`, `ports`, `find-port`, ...; plugins add their own through the `rio_cli` hook.
Commands import only what they need, inside the command, so `rio plugins list` stays fast. What every
command shares (`--json`, one error line, `rio --debug`, shell completion): docs/cli.md.
"""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `rio` script; returns the exit status (rio.cli.app.RioGroup says which).

    Ctrl-C while the command line itself is imported (typer, rich: the first half second of every
    command) is an interruption like any other: one line and 130, not a KeyboardInterrupt traceback. That
    is why this module and `rio/__init__.py` import next to nothing: the script's `from rio.cli import main`
    runs before any handler can."""
    _stacks_on_sigusr1()
    try:
        from rio.cli.app import run
    except KeyboardInterrupt:
        sys.stderr.write("error: interrupted\n")
        return 130  # rio.cli.app.EXIT_INTERRUPTED, which could not be imported
    return run(sys.argv[1:] if argv is None else argv)


def _stacks_on_sigusr1() -> None:
    """`kill -USR1 PID` prints every thread's stack to stderr and the command goes on: what a command that
    seems stuck is doing (a station that does not stop, an emulator that ignores Ctrl-C), without a debugger."""
    import faulthandler
    import signal

    if hasattr(signal, "SIGUSR1"):
        try:
            faulthandler.register(signal.SIGUSR1, all_threads=True, chain=False)
        except (OSError, ValueError, RuntimeError):  # stderr with no file descriptor (run inside a capture)
            pass
