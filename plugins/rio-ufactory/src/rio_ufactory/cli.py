"""`rio ufactory ...`: run the emulator, and recover an arm from a shell (clear errors, enable,
status) while a station runs or without one. Each command talks to the controller through the SDK
directly (the controller accepts several clients), so it works whatever holds the arm."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Annotated, Any

import typer

app = typer.Typer(help="UFACTORY xArm / Lite 6: emulator, status, clear errors, enable.", no_args_is_help=True)

Ip = Annotated[str, typer.Option("--ip", help="controller IP address")]


@contextmanager
def _connection(ip: str) -> Iterator[Any]:
    """A connection to the control box at `ip` for one command; an `XArmError` (no answer, a fault that will
    not clear) is printed as one line and exits 1."""
    from .connection import XArmConnection
    from .faults import XArmError

    try:
        with contextlib.redirect_stdout(sys.stderr):  # the SDK's connection chatter: stdout is for results
            conn = XArmConnection.acquire(ip, connect_timeout_s=3.0)
    except XArmError as e:
        typer.echo(f"error: {e}", err=True)
        raise typer.Exit(1) from None
    try:
        yield conn
    except XArmError as e:
        typer.echo(f"error: {e}", err=True)
        raise typer.Exit(1) from None
    finally:
        conn.release()


@app.command()
def status(ip: Ip,
           json_out: Annotated[bool, typer.Option("--json", help="Print it as JSON (stdout).")] = False) -> None:
    """Model, state, mode, error and warning of a controller."""
    with _connection(ip) as conn:
        api = conn.api
        fault = conn.fault()
        if json_out:
            from rio.cli.output import print_json

            print_json({"ip": ip, "model": conn.model.label if conn.model else None, "axis": api.axis,
                        "device_type": api.device_type, "firmware": api.version, "state": api.state,
                        "mode": api.mode, "joints_rad": [float(a) for a in conn.joints(api.axis)[0]],
                        "fault": str(fault) if fault else None})
            return
        typer.echo(f"{ip}: {conn.model.label if conn.model else 'unknown model'} (axis {api.axis}, type "
                   f"{api.device_type}), firmware {api.version}")
        joints = [round(a, 4) for a in conn.joints(api.axis)[0]]
        typer.echo(f"state {api.state}, mode {api.mode}, joints (rad) {joints}")
        typer.echo(f"fault: {fault}" if fault else "no fault")


@app.command("clear-errors")
def clear_errors(ip: Ip) -> None:
    """Clear the controller's error and warning (release an emergency stop first)."""
    with _connection(ip) as conn:
        before = conn.fault()
        conn.clear_faults()
        typer.echo(f"{ip}: cleared {before}" if before else f"{ip}: nothing to clear")
        typer.echo("next: `rio ufactory enable --ip IP`, or the station node's enable()/clear_faults()")


@app.command()
def enable(ip: Ip) -> None:
    """Motors on, servo mode, ready (what a station does at start)."""
    with _connection(ip) as conn:
        conn.enable_servo()
        typer.echo(f"{ip}: enabled, servo mode")


@app.command()
def emulator(
    model: Annotated[str, typer.Option("--model", help="xarm5, xarm6, xarm7, xarm850 or lite6")] = "xarm7",
    ip: Annotated[str, typer.Option("--ip", help="loopback address to listen on")] = "127.0.0.2",
    sim: Annotated[str | None, typer.Option("--sim", help='back the joints with a running rio-sim world: "sim" '
                                                          'or "sim:ARM@WORLD"')] = None,
    gripper: Annotated[str, typer.Option("--gripper", help="xarm, bio, lite6, robotiq or none")] = "xarm",
) -> None:
    """Serve an emulated controller until Ctrl-C; point a driver (or UFACTORY's own tools) at --ip."""
    from .emulator import serve

    serve(model=model, host=ip, backend=sim or "model", gripper=None if gripper == "none" else gripper)
