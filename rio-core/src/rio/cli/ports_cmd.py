"""`rio ports` (the serial ports on this machine) and `rio find-port` (which one is this device?
LeRobot's `lerobot-find-port`: unplug it, see which port went). The work is in `rio.machine.ports`."""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from rio.cli.args import positive

#: `--replug` without `--timeout`: how long to wait for the device to come back.
REPLUG_WAIT_S = 60.0

JsonOption = Annotated[bool, typer.Option("--json", help="Machine-readable output.")]


def ports(as_json: JsonOption = False) -> None:
    """Serial ports on this machine (USB adapters of servo buses, grippers): device, stable
    /dev/serial/by-id path (use it in station files), USB vid:pid, serial number, description."""
    from rio.cli.output import print_json, table
    from rio.machine import ports as P

    found = P.list_ports()
    if as_json:
        print_json([p.to_json() for p in found])
        return
    if not found:
        typer.echo("no serial port found (plug the device in; `rio find-port` tells which port is which)")
        return
    table("serial ports", ("device", "by-id", "usb", "serial", "description"),
          [(p.device, p.by_id or "-", p.usb_id or "-", p.serial_number or "-", p.description or "-") for p in found])


def find_port(
    timeout: Annotated[float | None, typer.Option(
        "--timeout", "-t", callback=positive,
        help="Don't ask for Enter: watch this many seconds for a device to be unplugged (or plugged in), "
             "and with --replug as long again for it to come back (scripts).")] = None,
    replug: Annotated[bool, typer.Option(
        "--replug", help="After the device is unplugged, wait for it to come back and report the port it "
                         "returns on (it may differ: use its by-id path).")] = False,
    as_json: JsonOption = False,
) -> None:
    """Which serial port is a device on: unplug its USB cable when asked (then press Enter); the port that
    disappeared is the device's (LeRobot's lerobot-find-port). Instructions go to stderr, the answer to
    stdout."""
    from rio.cli.output import print_json
    from rio.errors import RioError
    from rio.machine import ports as P

    def say(message: str) -> None:
        typer.echo(message, err=True)

    before = P.list_ports()
    say(f"serial ports now: {', '.join(p.device for p in before) or 'none'}")
    if timeout is None:
        say("Plug the device in (no serial port is there now), then press Enter." if not before else
            "Unplug the device's USB cable, then press Enter.")
        if not sys.stdin.readline():
            raise RioError("no Enter: stdin is closed; in a script use `rio find-port --timeout SECONDS`")
        c = P.wait_for_change(P.list_ports, before, P.AFTER_ENTER_S)
    else:
        say(f"Unplug the device's USB cable now (or plug it in); watching for {timeout:g} s ...")
        c = P.wait_for_change(P.list_ports, before, timeout)
        if not c:
            raise RioError(f"no serial port disappeared or appeared within {timeout:g} s (ports: "
                           f"{', '.join(p.device for p in before) or 'none'})")
    event, port = P.the_port(c, before)
    back = None
    if replug and event == "unplugged":
        wait = timeout if timeout is not None else REPLUG_WAIT_S
        say(f"{port.device} is gone. Plug the cable back in; waiting up to {wait:g} s ...")
        unplugged = [p for p in before if p.device != port.device]  # so a quick replug counts too
        came = P.wait_for_change(P.list_ports, unplugged, wait, came_only=True).came
        if len(came) != 1:
            raise RioError(f"the device did not come back within {wait:g} s" if not came else
                           f"several ports appeared ({', '.join(p.device for p in came)}); plug in only the one device")
        back = came[0]
    if as_json:
        print_json({"event": event, "port": port.to_json(), "replugged": back.to_json() if back else None})
        return
    typer.echo(f"the device's port is {port.summary()}" + (" (it was plugged in)" if event == "plugged" else ""))
    if back is not None and back.device != port.device:
        typer.echo(f"it came back as {back.summary()}: its name changed, so use its by-id path")
    elif back is not None:
        typer.echo(f"it came back on {back.device}")
    final = back or port
    if final.by_id:
        typer.echo(f'in a station file: port = "{final.by_id}"  (stable: it names the adapter, not the order '
                   "of plugging)")
    if event == "unplugged" and back is None:
        say("Plug the cable back in.")
