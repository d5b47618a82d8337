"""`rio top [STATION]`: live per-node rates, sample age, CPU and memory of the stations running on this
machine (rio.runtime.top). `--once` measures one interval and prints it (scripts, `--json`)."""

from __future__ import annotations

import time
from typing import Annotated

import typer

from rio.cli.args import positive


def top(
    station: Annotated[str | None, typer.Argument(help="Only this station (default: every running one).")] = None,
    interval: Annotated[float, typer.Option("--interval", "-n", callback=positive,
                                            help="Seconds between updates.")] = 1.0,
    once: Annotated[bool, typer.Option("--once", help="Measure one interval, print, exit.")] = False,
    json_out: Annotated[bool, typer.Option("--json", help="With --once: the rows as JSON.")] = False,
) -> None:
    """Watch running stations like htop: each node's publishing rate, the age of its newest sample, and
    its process's CPU and memory. Read-only: it never sends a node anything."""
    from rio.cli.output import error, print_json
    from rio.runtime.top import StationTop, format_rows

    with StationTop(station) as watch:
        if not watch.watched:
            error("no running station" + (f" named '{station}'" if station else "") + " on this machine "
                  "(stations started by this user, with the same TMPDIR)")
            raise typer.Exit(1)
        try:
            while True:
                time.sleep(interval)
                rows = watch.rows()
                if json_out:
                    print_json(rows)
                else:
                    if not once:
                        typer.echo("\x1b[2J\x1b[H", nl=False)  # clear the terminal, like top
                    typer.echo(format_rows(rows, cpu_note=watch.psutil is None))
                if once:
                    return
        except KeyboardInterrupt:
            pass
