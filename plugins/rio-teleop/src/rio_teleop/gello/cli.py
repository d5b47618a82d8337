"""`rio gello ...`: calibrate a GELLO leader, watch what it reads. Leader-follower teleop itself is
`rio teleop STATION`. Each command imports what it needs when it runs; the work lives in `calibrate`."""

from __future__ import annotations

import time
from typing import Annotated

import typer

from rio.cli.args import positive, servo_port

from .layouts import LAYOUTS

app = typer.Typer(help="GELLO leader arms (Dynamixel XL330): calibrate, read. Teleop: `rio teleop STATION`.",
                  no_args_is_help=True)

Port = Annotated[str, typer.Option("--port", "-p", callback=servo_port,
                                   help='the U2D2 (/dev/serial/by-id/usb-FTDI_...), or "emulator"')]
LayoutOpt = Annotated[str, typer.Option("--layout", "-l", help="GELLO design: " + ", ".join(LAYOUTS))]
Baud = Annotated[int, typer.Option("--baudrate", callback=positive, help="the servos' baud rate")]


def _check_layout(layout: str):
    from .layouts import get_layout

    try:
        return get_layout(layout)
    except ValueError as e:
        raise typer.BadParameter(str(e), param_hint="'--layout'") from None


@app.command()
def calibrate(port: Port, layout: LayoutOpt, name: Annotated[str, typer.Option(
        "--name", help="calibration name (station files: `calibration = NAME`) or a .json path")] = "default",
        baudrate: Baud = 57600,
        squeeze: Annotated[bool, typer.Option("--squeeze/--no-squeeze",
                                              help="also record the trigger squeezed")] = True) -> None:
    """Hold the leader in its layout's known pose: find each joint's offset (a multiple of pi/2)."""
    from .calibrate import calibrate_leader
    from .calibration import save_calibration

    lay = _check_layout(layout)
    emu = None
    path = port
    if port == "emulator":
        from .emulator import GelloEmulator

        emu = GelloEmulator(lay)
        path = emu.port
        typer.echo(f"emulated GELLO on {path}: a scripted hand holds it in the pose")
    pose = ", ".join(f"{q:+.3f}" for q in lay.known_pose)
    prompts = {"known pose": f"Hold the leader in the known pose ({pose}) rad, trigger released; press Enter.",
               "squeeze": "Keep the pose and squeeze the trigger fully; press Enter."}

    def wait(step: str) -> None:
        typer.echo(prompts[step])
        if emu is None:
            input()
        elif step == "squeeze":
            emu.pose(lay.known_pose, gripper=0.0)
            time.sleep(0.05)

    try:
        cal = calibrate_leader(path, lay, name=name, baudrate=baudrate, wait=wait, squeeze=squeeze, label=port)
    finally:
        if emu is not None:
            emu.close()
    saved = save_calibration(cal)
    typer.echo(f"saved {saved}")
    for k, (off, sign, res) in enumerate(zip(cal.offsets, cal.signs, cal.residual, strict=True)):
        typer.echo(f"  joint{k + 1}: offset {off / (3.141592653589793 / 2):+.0f} x pi/2, sign {sign:+d}, "
                   f"left over {res:+.3f} rad")
    typer.echo(f"  trigger: open {cal.gripper_open:.3f} rad, closed {cal.gripper_closed:.3f} rad")


@app.command()
def read(port: Port, layout: LayoutOpt, calibration: Annotated[str, typer.Option(
        "--calibration", help="calibration name or .json path")] = "default", baudrate: Baud = 57600,
        seconds: Annotated[float, typer.Option("--seconds", callback=positive,
                                               help="how long to print")] = 10.0,
         json_out: Annotated[bool, typer.Option("--json", help="One JSON object per reading (stdout).")] = False,
         ) -> None:
    """Print the follower joint angles the leader reads, 5 times a second (check a calibration)."""
    from .driver import GelloLeader

    _check_layout(layout)
    node = GelloLeader(port=port, layout=layout, calibration=calibration, baudrate=baudrate)
    node.setup()
    node.open()
    try:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            s = node.read_state()
            if json_out:
                import json

                typer.echo(json.dumps({"joint_pos": [float(q) for q in s["joint_pos"]],
                                       "gripper": float(s["gripper"])}))
            else:
                typer.echo("  ".join(f"{q:+.3f}" for q in s["joint_pos"]) + f"   gripper {s['gripper']:.2f}")
            time.sleep(0.2)
    finally:
        node.close()
