"""`rio franka ...`: look at a robot and recover it from a shell (while a station runs or without one).
Each command opens its own franky connection (libfranka allows one controlling client: run `recover`
while no motion runs, e.g. while the station's node holds a fault). `--backend fake` reaches a fake
control box of this process (tests)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Annotated, Any

import typer

app = typer.Typer(help="Franka FR3 / Panda: status and error recovery.", no_args_is_help=True)

Ip = Annotated[str, typer.Option("--ip", help="the robot's FCI address (Desk's IP), e.g. 172.16.0.2")]
Backend = Annotated[str, typer.Option("--backend", help='"franky" (the robot) or "fake" (a fake control box)')]


@contextmanager
def _robot(ip: str, backend: str) -> Iterator[Any]:
    """The robot at `ip` for one command; a failed connection or call is printed as one line and exits 1."""
    from .backend import connect_robot
    from .faults import FrankaError

    try:
        robot = connect_robot(ip, backend, None, 0.1, realtime=False)  # no motion: no real-time loop needed
    except (FrankaError, ValueError) as e:
        typer.echo(f"error: {e}", err=True)
        raise typer.Exit(1) from None
    try:
        yield robot
    except Exception as e:  # franky's exceptions are not importable without franky
        typer.echo(f"error: Franka at {ip}: {type(e).__name__}: {e}", err=True)
        raise typer.Exit(1) from None


@app.command()
def status(ip: Ip, backend: Backend = "franky",
           json_out: Annotated[bool, typer.Option("--json", help="Print it as JSON (stdout).")] = False) -> None:
    """Robot mode, fault and joints of a robot, and the franky / libfranka installed here."""
    from .backend import versions
    from .faults import fault_of_state, robot_mode

    with _robot(ip, backend) as robot:
        st = robot.state
        fault = fault_of_state(st)
        if json_out:
            from rio.cli.output import print_json

            print_json({"ip": ip, "mode": str(robot_mode(st)), "joints_rad": [float(a) for a in st.q],
                        "fault": str(fault) if fault else None,
                        "versions": versions() if backend == "franky" else None})
            return
        typer.echo(f"{ip}: mode {robot_mode(st)}, joints (rad) {[round(float(a), 4) for a in st.q]}")
        if backend == "franky":
            typer.echo(versions())
        typer.echo(f"fault: {fault}" if fault else "no fault")


@app.command()
def recover(ip: Ip, backend: Backend = "franky") -> None:
    """libfranka's automatic error recovery (`recover_from_errors()`); release a user stop first."""
    from .faults import fault_of_state

    with _robot(ip, backend) as robot:
        before = fault_of_state(robot.state)
        robot.recover_from_errors()
        after = fault_of_state(robot.state)
        if after is not None:
            typer.echo(f"error: Franka at {ip}: still faulted: {after}", err=True)
            raise typer.Exit(1)
        typer.echo(f"{ip}: cleared {before.name}" if before else f"{ip}: nothing to clear")
        typer.echo("next: the station node's clear_faults() (or enable()) to command the arm again")
