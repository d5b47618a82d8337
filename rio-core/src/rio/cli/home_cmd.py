"""`rio home STATION`: move every joint device of a station to its home pose (or `--rest`), and the options
`--home`, `--home-speed` and `--yes` that teleop, deploy and replay share. All motion is done by
`rio.workflows.home`; on real hardware it asks first (`confirm_homing`), on sim, fake and emulator stations not."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from rio.cli.args import positive
from rio.cli.run_cmd import MiddlewareOption, ReadyTimeoutOption, StationArgument

#: The fastest joint's speed while homing (rad/s); `rio.workflows.home.HOME_SPEED` (a test keeps them equal:
#: this module stays free of numpy, so listing commands stays fast).
HOME_SPEED = 0.3

HomeOption = Annotated[bool, typer.Option(
    "--home", help="Move every joint device to its home pose (at --home-speed) before the run; asks first on "
                   "real hardware.")]
HomeSpeedOption = Annotated[float, typer.Option(
    "--home-speed", callback=positive, metavar="RAD/S", help="Speed of the fastest joint while homing (rad/s).")]
YesOption = Annotated[bool, typer.Option("--yes", "-y", help="Do not ask before homing real hardware.")]


def confirm_homing(station: Any, speed: float, yes: bool, what: str = "home") -> float:
    """`speed`, once the operator agreed to move the station's robot (real hardware only; `--yes` agrees).
    Without a terminal to ask, real hardware is not moved unasked: the command ends, saying to pass --yes."""
    import sys

    from rio.workflows.home import is_stand_in

    if yes or is_stand_in(station):
        return speed
    if not sys.stdin.isatty():
        raise typer.BadParameter(f"station '{station.name}' drives real hardware: homing moves it; there is no "
                                 "terminal to ask, pass --yes to move it anyway", param_hint="--home")
    if not typer.confirm(f"Move every joint of station '{station.name}' to its {what} pose at {speed:g} rad/s? "
                         "Clear the robot's path first", default=False, err=True):
        raise typer.Exit(1)
    return speed


def home(
    station: StationArgument,
    speed: HomeSpeedOption = HOME_SPEED,
    rest: Annotated[bool, typer.Option("--rest", help="Move to the rest pose the driver or station declares "
                                                      "(where the robot is parked) instead of home.")] = False,
    yes: YesOption = False,
    middleware: MiddlewareOption = None,
    ready_timeout: ReadyTimeoutOption = None,
) -> None:
    """Move a station's arms, hands or humanoid to their home pose at a bounded speed, then stop the station.
    Exits 1 when a device did not arrive."""
    from rio.station.load import load_station
    from rio.workflows.home import run_home

    st = load_station(station)
    confirm_homing(st, speed, yes, "rest" if rest else "home")
    result = run_home(st, speed=speed, rest=rest, middleware=middleware, ready_timeout=ready_timeout,
                      log=lambda m: typer.echo(m, err=True))
    for line in result.lines():
        typer.echo(line)
    if not result.arrived:
        raise typer.Exit(1)
