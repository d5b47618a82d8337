"""`rio ur ...`: the Dashboard Server's commands from a shell (power, brakes, protective stop, popups,
programs, status) and the emulator. Each command opens ur-rtde's `DashboardClient` on port 29999, which
the controller serves to several clients, so it works while a station holds the arm."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Annotated, Any

import typer

app = typer.Typer(help="Universal Robots: dashboard commands, status, emulator.", no_args_is_help=True)
Ip = Annotated[str, typer.Option("--ip", help="controller IP address")]


@contextmanager
def _dashboard(ip: str) -> Iterator[Any]:
    from dashboard_client import DashboardClient

    d = DashboardClient(ip)
    try:
        d.connect()
    except RuntimeError as e:
        typer.echo(f"error: no Dashboard Server at {ip}:29999 ({e})", err=True)
        raise typer.Exit(1) from None
    try:
        yield d
    finally:
        d.disconnect()


def _simple(name: str, call: Callable[[Any], Any], doc: str) -> None:
    def cmd(ip: Ip) -> None:
        with _dashboard(ip) as d:
            call(d)
            typer.echo(f"{ip}: {name} sent; {d.robotmode()}, {d.safetystatus()}")

    cmd.__doc__ = doc
    app.command(name)(cmd)


_simple("power-on", lambda d: d.powerOn(), "Power the arm on (brakes stay on).")
_simple("power-off", lambda d: d.powerOff(), "Power the arm off.")
_simple("brake-release", lambda d: d.brakeRelease(), "Release the brakes (the arm goes to RUNNING).")
_simple("unlock-protective-stop", lambda d: d.unlockProtectiveStop(), "Unlock a protective stop (cause removed).")
_simple("close-safety-popup", lambda d: d.closeSafetyPopup(), "Close the pendant's safety popup.")
_simple("restart-safety", lambda d: d.restartSafety(), "Restart the safety system (after a violation or fault).")
_simple("play", lambda d: d.play(), "Play the loaded program.")
_simple("stop", lambda d: d.stop(), "Stop the running program.")


@app.command("load")
def load(ip: Ip, program: Annotated[str, typer.Argument(help="program file on the controller (.urp)")]) -> None:
    """Load a program."""
    with _dashboard(ip) as d:
        d.loadURP(program)
        typer.echo(f"{ip}: {d.getLoadedProgram()}")


@app.command()
def status(ip: Ip,
           json_out: Annotated[bool, typer.Option("--json", help="Print it as JSON (stdout).")] = False) -> None:
    """Robot mode, safety status, program state, remote control, software version."""
    with _dashboard(ip) as d:
        if json_out:
            from rio.cli.output import print_json

            print_json({"ip": ip, "version": str(d.polyscopeVersion()), "robot_mode": str(d.robotmode()),
                        "safety_status": str(d.safetystatus()), "program_state": str(d.programState()),
                        "remote_control": bool(d.isInRemoteControl())})
            return
        typer.echo(f"{ip}: {d.polyscopeVersion()}")
        typer.echo(f"{d.robotmode()}; {d.safetystatus()}; program {d.programState()}")
        typer.echo(f"remote control: {str(d.isInRemoteControl()).lower()}")


@app.command()
def emulator(
    model: Annotated[str, typer.Option("--model", help="ur3e ... ur30")] = "ur5e",
    ip: Annotated[str, typer.Option("--ip", help="loopback address to listen on")] = "127.0.0.2",
    sim: Annotated[str | None, typer.Option("--sim", help='back the joints with a rio-sim world: "sim" or '
                                                          '"sim:ARM@WORLD"')] = None,
    urcap: Annotated[bool, typer.Option("--urcap", help="also serve a Robotiq URCap socket (63352)")] = False,
    exit_with: Annotated[int | None, typer.Option("--exit-with", help="exit when the process with this id, the "
                                                                       "one that started this, exits")] = None,
) -> None:
    """Serve an emulated controller (dashboard, RTDE, servo port) until Ctrl-C or SIGTERM (what the test
    fixtures, the bench and the station's `ur.emulator` node run, in a process of their own)."""
    import threading

    from rio.machine import host

    from .emulator import UREmulator

    if exit_with is not None:
        host.exit_with_parent(exit_with)

    emu = UREmulator(model, host=ip, backend=sim or "model", urcap=urcap).start()
    typer.echo(f"{emu.arm.label} emulator on {ip} (dashboard 29999, RTDE 30004, servo 30020); backend "
               f"{sim or 'model'}; drivers: ip = \"{ip}\", control = \"emulator\"; Ctrl-C stops")
    try:
        threading.Event().wait()
    except KeyboardInterrupt:
        pass
    finally:
        emu.stop()
