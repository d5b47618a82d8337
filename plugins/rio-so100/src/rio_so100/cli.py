"""`rio so100 ...`: calibrate an arm (or import its LeRobot calibration), serve an emulated bus, torque,
scan. Leader-follower teleop is `rio teleop STATION` (a station whose teleop device is a leader arm is
mirrored joint by joint).

Mounted by the plugin's `rio_cli` hook. Each command imports what it needs when it runs; the work
itself lives in importable modules (`calibrate`, `emulator`), so scripts and tests
call exactly what the commands run.
"""

from __future__ import annotations

import select
import sys
import time
from typing import Annotated

import typer

from rio.cli.args import not_empty, one_of, positive, servo_port
from rio.cli.renamed import keep_old_name

app = typer.Typer(help="SO-100 / SO-101 arms on the Feetech bus: calibrate, emulated bus, torque, scan "
                       "(leader-follower teleop: `rio teleop STATION`).",
                  no_args_is_help=True)

Port = Annotated[str, typer.Option("--port", "-p", callback=servo_port,
                                   help='serial port (e.g. /dev/ttyACM0), or "emulator"')]


def _enter_pressed(timeout: float) -> bool:
    """True once the user pressed Enter (waits at most `timeout`)."""
    ready, _, _ = select.select([sys.stdin], [], [], timeout)
    if ready:
        sys.stdin.readline()
        return True
    return False


@app.command()
def calibrate(
    port: Annotated[str | None, typer.Option(
        "--port", "-p", callback=servo_port,
        help='serial port (e.g. /dev/ttyACM0), or "emulator"; not with --from-lerobot')] = None,
    device: Annotated[str | None, typer.Option(
        "--device", callback=one_of("follower", "leader"),
        help="follower or leader (default: follower, or what LeRobot's folder says)")] = None,
    model: Annotated[str | None, typer.Option(
        "--model", callback=one_of("so100", "so101"),
        help="so100 or so101 (default: so100, or what LeRobot's folder says)")] = None,
    name: Annotated[str | None, typer.Option(
        "--name", help="calibration name (left, right, ...) used by station files as `calibration = NAME`, or a "
                       ".json path (default: default; emulator-demo with --port emulator; the LeRobot id with "
                       "--from-lerobot)")] = None,
    from_lerobot: Annotated[str | None, typer.Option(
        "--from-lerobot", metavar="FILE|ID", callback=not_empty,
        help="import a LeRobot calibration instead of recording one (the arm is not touched): its .json file, "
             "or the id it was calibrated under, looked up in $HF_LEROBOT_CALIBRATION (default "
             "~/.cache/huggingface/lerobot/calibration)")] = None,
) -> None:
    """Calibrate one arm: record its middle pose, then each joint's range of motion (or import LeRobot's)."""
    if from_lerobot is not None:
        if port is not None:
            raise typer.BadParameter("--from-lerobot imports a file and does not talk to the arm: leave out --port",
                                     param_hint="'--port'")
        _import_lerobot(from_lerobot, model, device, name)
        return
    if port is None:
        raise typer.BadParameter("missing: give the arm's bus (or --from-lerobot FILE|ID to import a LeRobot "
                                 "calibration)", param_hint="'--port'")
    device, model = device or "follower", model or "so100"
    from .calibrate import Calibrator
    from .calibration import calibration_path, save_calibration
    from .connection import check_present, is_emulator
    from .feetech.bus import FeetechBus
    from .models import ARM_IDS, ARM_JOINTS, GRIPPER, GRIPPER_ID

    joints = {**dict(zip(ARM_JOINTS, ARM_IDS, strict=True)), GRIPPER: GRIPPER_ID}
    emu = hand = None
    path = port
    if is_emulator(port):
        from .emulator import FeetechBusEmulator
        from .emulator.hand import CalibrationHand

        emu = FeetechBusEmulator()
        hand = CalibrationHand(emu)
        path = emu.port
        typer.echo(f"emulated arm on {path}: a scripted hand answers the prompts")
    name = name or ("emulator-demo" if emu is not None else "default")
    try:
        with FeetechBus(path, names={v: k for k, v in joints.items()}) as bus:
            check_present(bus, joints.values(), port)
            cal = Calibrator(bus, joints)
            cal.prepare()
            typer.echo(f"Calibrating the {model} {device} '{name}' on {port}. Torque is off: move the arm by hand.")
            typer.echo("1. Put every joint in the middle of its range (gripper half open), then press Enter.")
            if hand is not None:
                hand.hold_middle()
                time.sleep(0.1)
            else:
                input()
            cal.record_middle()
            typer.echo("2. Move every joint, one at a time, through its whole range; press Enter when done.")
            t_end, t_show = None, 0.0
            if hand is not None:
                hand.sweep(1.5)
                t_end = time.monotonic() + 1.7
            while True:
                seen = cal.sample()
                if time.monotonic() > t_show:  # a live line, 5 times a second
                    t_show = time.monotonic() + 0.2
                    typer.echo("\r" + "  ".join(f"{j} {lo}..{hi}" for j, (lo, _, hi) in seen.items()), nl=False)
                if t_end is not None:
                    time.sleep(0.02)
                    if time.monotonic() > t_end:
                        break
                elif _enter_pressed(0.05):
                    break
            typer.echo("")
            result = cal.finish(model, device, name)
        saved = save_calibration(result, calibration_path(name, model, device))
        typer.echo(f"saved {saved}")
        _show(result)
    finally:
        if emu is not None:
            emu.close()


def _show(cal) -> None:
    for j, jc in cal.joints.items():
        lo, hi = jc.limits_rad()
        typer.echo(f"  {j:14s} id {jc.id}  offset {jc.homing_offset:+5d}  range {jc.range_min}..{jc.range_max} "
                   f"steps = {lo:+.2f}..{hi:+.2f} rad")


def _import_lerobot(source: str, model: str | None, device: str | None, name: str | None) -> None:
    """`calibrate --from-lerobot`: convert a LeRobot calibration file into RIO's (rio_so100.lerobot_calibration)."""
    from .calibration import calibration_path, save_calibration
    from .lerobot_calibration import import_lerobot

    cal, found = import_lerobot(source, model=model, device=device, name=name)
    path = calibration_path(cal.name, cal.model, cal.device)
    replaced = path.is_file()
    save_calibration(cal, path)
    guessed = [f"--{what} {value}" for what, given, says, value in
               (("model", model, found.model, cal.model), ("device", device, found.device, cal.device))
               if given is None and says is None]
    typer.echo(f"imported LeRobot calibration {found.path} as the {cal.model} {cal.device} '{cal.name}'"
               + (f" (LeRobot's folder does not say: assumed {', '.join(guessed)})" if guessed else ""))
    typer.echo(f"saved {path}" + (" (replacing the previous file)" if replaced else "")
               + "; 0 rad is the middle of each joint's range, as LeRobot's degrees")
    _show(cal)


@app.command("emulator")
def emulator(
    ids: Annotated[str, typer.Option(help="servo ids on the bus, comma separated")] = "1,2,3,4,5,6",
    motion: Annotated[str, typer.Option(help="none, or wave: a scripted hand moves torque-off servos")] = "none",
    seconds: Annotated[float | None, typer.Option(callback=positive,
                                                  help="stop after this long (default: until Ctrl+C)")] = None,
) -> None:
    """Serve emulated STS3215 servos on a pseudo-terminal; use the printed path as a port."""
    from .emulator import FeetechBusEmulator
    from .emulator.hand import attach_motion

    bus = FeetechBusEmulator([int(i) for i in ids.split(",") if i.strip()])
    attach_motion(bus, motion)
    typer.echo(bus.port)
    typer.echo(f"emulated Feetech bus with servos {sorted(bus.servos)} on {bus.port} (Ctrl+C to stop); e.g. "
               f"port = \"{bus.port}\" in a station file", err=True)
    t_end = None if seconds is None else time.monotonic() + seconds
    try:
        while t_end is None or time.monotonic() < t_end:
            time.sleep(0.1)
    except KeyboardInterrupt:
        pass
    finally:
        bus.close()
        typer.echo(f"served {bus.stats['status']} status packets", err=True)


keep_old_name(app, "virtual-bus", "emulator", emulator)  # the old name, for one release


@app.command()
def torque(
    state: Annotated[str, typer.Argument(help="on or off")],
    port: Port,
    ids: Annotated[str, typer.Option(help="servo ids, comma separated")] = "1,2,3,4,5,6",
) -> None:
    """Enable (hold the present pose) or disable the torque of servos on a bus."""
    from .feetech import control_table as T
    from .feetech.bus import FeetechBus

    if state not in ("on", "off"):
        raise typer.BadParameter("state is on or off")
    id_list = [int(i) for i in ids.split(",") if i.strip()]
    with FeetechBus(port) as bus:
        for sid in id_list:
            if state == "on":
                bus.write(sid, T.GOAL_POSITION, bus.read(sid, T.PRESENT_POSITION))
            bus.write(sid, T.TORQUE_ENABLE, 1 if state == "on" else 0, check_error=state == "on")
    typer.echo(f"torque {state}: servos {id_list} on {port}")


@app.command()
def scan(
    port: Port,
    max_id: Annotated[int, typer.Option(min=1, max=253, help="highest id to ping")] = 12,
    json_out: Annotated[bool, typer.Option("--json", help="Print it as JSON (stdout).")] = False,
) -> None:
    """Ping ids 1..MAX_ID and list the servos that answer (model, position, voltage, temperature)."""
    from .feetech import control_table as T
    from .feetech.bus import FeetechBus

    with FeetechBus(port) as bus:
        found = {sid: m for sid, m in bus.find(range(1, max_id + 1)).items() if m is not None}
        if not found:
            typer.echo(f"no servo answered on {port} (ids 1..{max_id})")
            raise typer.Exit(1)
        if json_out:
            from rio.cli.output import print_json

            print_json([{"id": sid, "model": model, "position": bus.read(sid, T.PRESENT_POSITION),
                         "voltage_v": bus.read(sid, T.PRESENT_VOLTAGE) / 10,
                         "temperature_c": bus.read(sid, T.PRESENT_TEMPERATURE)} for sid, model in found.items()])
            return
        for sid, model in found.items():
            typer.echo(f"id {sid}: model {model}, position {bus.read(sid, T.PRESENT_POSITION)}, "
                       f"{bus.read(sid, T.PRESENT_VOLTAGE) / 10:.1f} V, {bus.read(sid, T.PRESENT_TEMPERATURE)} C")
