"""`rio unitree ...`: run the G1 sim (`bridge`: MuJoCo physics behind the robot's DDS topics), check that a
robot is heard (check), make it soft (damp), release Unitree's locomotion (debug-mode) and ramp it to its home
pose (stand). Each talks DDS directly, so it works beside a running station."""

from __future__ import annotations

import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Annotated

import typer

from rio.cli.args import non_negative, positive

app = typer.Typer(
    help="Unitree G1: the G1 sim (bridge: MuJoCo physics behind the robot's DDS topics), bring-up check, damping, "
    "debug mode, stand.", no_args_is_help=True
)

Interface = Annotated[str, typer.Option("--interface", help="network interface on the robot's network (192.168.123.x)")]
Domain = Annotated[int, typer.Option("--domain-id", min=0, max=232, help="DDS domain, 0..232 (the robot's is 0)")]
Yes = Annotated[bool, typer.Option("--yes", help="no confirmation (the robot hangs: you checked)")]


def _interrupt(*_: object) -> None:
    raise KeyboardInterrupt


@app.command()
def bridge(
    interface: Annotated[str, typer.Option("--interface", help="interface to publish on")] = "lo",
    domain_id: Domain = 0,
    model: Annotated[
        str | None,
        typer.Option(
            "--model",
            help='MJCF path, "fallback", or "hands" (rio-sim\'s G1 with '
            "Dex3-1 hands: also rt/dex3/*) (default: rio-sim's G1 "
            "when installed, else the plugin's own)",
        ),
    ] = None,
    inspire: Annotated[
        bool, typer.Option("--inspire", help="also play the G1's two Inspire hands (rt/inspire/*, emulated servos)")
    ] = False,
    free: Annotated[
        bool,
        typer.Option(
            "--free", help="pelvis free on a floor instead of welded (it will fall: there is no balance controller)"
        ),
    ] = False,
    gantry: Annotated[
        bool,
        typer.Option(
            "--gantry",
            help="free pelvis held up by a gantry until released (Enter, or --release-after), then lowered onto "
            "its feet (implies --free)",
        ),
    ] = False,
    release_after: Annotated[
        float | None,
        typer.Option(
            "--release-after",
            callback=non_negative,
            help="with --gantry: lower it this many seconds after the legs are first commanded stiff on rt/lowcmd",
        ),
    ] = None,
    lower_s: Annotated[
        float, typer.Option("--lower-s", callback=positive, help="with --gantry: seconds lowering takes")
    ] = 2.0,
    state_rate_hz: Annotated[
        float, typer.Option("--state-rate-hz", callback=positive, help="rt/lowstate rate")
    ] = 500.0,
    seconds: Annotated[
        float | None, typer.Option("--seconds", callback=positive, help="stop after this long (default: Ctrl-C)")
    ] = None,
) -> None:
    """The G1 sim: MuJoCo physics behind rt/lowstate, rt/lowcmd and rt/arm_sdk until Ctrl-C (what the g1-sim
    stations run as a component); point a driver (or
    Unitree's SDK examples) at --interface and --domain-id. With --gantry the free G1 hangs, as a real one
    is brought up on its hoist, until you press Enter (or --release-after passes once its legs are held)."""
    from .bridge import Bridge

    with _sigterm_as_ctrl_c():
        if release_after is not None and not gantry:
            typer.echo("error: --release-after releases the gantry: add --gantry", err=True)
            raise typer.Exit(1)
        free = free or gantry
        try:
            b = Bridge(domain_id=domain_id, interface=interface, model=model, mounted=not free,
                       state_rate_hz=state_rate_hz, gantry=gantry, release_after_s=release_after, lower_s=lower_s,
                       hands="inspire" if inspire else None)
        except (ValueError, OSError) as e:
            typer.echo(f"error: {e}", err=True)
            raise typer.Exit(1) from None
        with b:
            hands = (f", hands {' and '.join(sorted(b.sim.hands))}" if b.sim.hands
                     else ", Inspire hands" if inspire else "")
            typer.echo(
                f"G1 bridge on {interface}, DDS domain {domain_id}: model {b.sim.source}{hands}, "
                f"{'on its gantry' if gantry else 'free' if free else 'mounted'}, {1 / b.dt:.0f} Hz; Ctrl-C to stop",
                err=True,
            )
            enter = gantry and sys.stdin.isatty()
            if gantry:
                when = ([f"{release_after:g} s after its legs are held stiff on rt/lowcmd"]
                        if release_after is not None else [])
                when += ["when you press Enter"] if enter else []
                typer.echo(f"the gantry holds it; it is lowered onto its feet over {lower_s:g} s "
                           + (" or ".join(when) or "never (no terminal, no --release-after)"), err=True)
            t_end = None if seconds is None else time.monotonic() + seconds
            try:
                while t_end is None or time.monotonic() < t_end:
                    if enter and _enter_pressed(0.1):
                        b.release_gantry()
                        enter = False
                        typer.echo("lowering the gantry", err=True)
                    else:
                        time.sleep(0.1)
                    if not b.running:
                        typer.echo("error: the bridge stopped (see the log above)", err=True)
                        raise typer.Exit(1)
            except KeyboardInterrupt:
                pass
            c = b.counts
        typer.echo(
            f"stopped: {c.steps} steps, {c.lowstate} lowstate sent, {c.lowcmd} lowcmd and {c.arm_sdk} arm_sdk "
            f"received, {c.bad_crc} with a bad CRC ignored",
            err=True,
        )


@contextmanager
def _sigterm_as_ctrl_c() -> Iterator[None]:
    """`kill` stops the bridge as Ctrl-C does; the process's own SIGTERM handler is back afterwards (the command
    may run inside another program: a test, a notebook)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGTERM, _interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


def _enter_pressed(timeout: float) -> bool:
    """Whether a line was typed at the terminal within `timeout` s (the line is consumed)."""
    import select

    ready, _, _ = select.select([sys.stdin], [], [], timeout)
    if ready:
        sys.stdin.readline()
    return bool(ready)


@app.command()
def check(
    interface: Interface,
    domain_id: Domain = 0,
    timeout: Annotated[
        float, typer.Option("--timeout", callback=positive, help="seconds to wait for rt/lowstate")
    ] = 3.0,
    json_out: Annotated[bool, typer.Option("--json", help="Print it as JSON (stdout).")] = False,
) -> None:
    """First bring-up step: the interface has an address and the robot's rt/lowstate arrives."""
    from .tools import check as run_check

    report = run_check(interface, domain_id, timeout)
    if json_out:
        from rio.cli.output import print_json

        print_json(
            {"ok": bool(report.ok), "lines": list(report.lines), "problem": None if report.ok else report.problem}
        )
        raise typer.Exit(0 if report.ok else 1)
    for line in report.lines:
        typer.echo(line)
    if not report.ok:
        typer.echo(f"error: {report.problem}", err=True)
        raise typer.Exit(1)
    typer.echo("ok: the robot is heard")


@app.command()
def damp(
    interface: Interface,
    domain_id: Domain = 0,
    seconds: Annotated[float, typer.Option("--seconds", callback=positive, help="how long to send damping")] = 3.0,
) -> None:
    """Send damping (kp = 0, kd > 0) on rt/lowcmd for --seconds: the robot goes soft. Only obeyed with
    Unitree's locomotion released (debug mode); in normal mode use the remote (L2+B)."""
    from .tools import damp as run_damp

    try:
        sent = run_damp(interface, domain_id, seconds)
    except ValueError as e:
        typer.echo(f"error: {e}", err=True)
        raise typer.Exit(1) from None
    typer.echo(f"sent {sent} damping commands on rt/lowcmd ({interface}, DDS domain {domain_id})")


def _confirm(yes: bool, risk: str) -> None:
    """Go on with --yes, or when the operator types y at a terminal; refuse otherwise, naming the risk."""
    if yes:
        return
    if not sys.stdin.isatty():
        typer.echo(f"error: refusing without --yes: {risk}", err=True)
        raise typer.Exit(1)
    if not typer.confirm(f"{risk}\nGo on?", default=False):
        raise typer.Exit(1)


@app.command("debug-mode")
def debug_mode(
    interface: Interface,
    domain_id: Domain = 0,
    check_only: Annotated[bool, typer.Option("--check", help="only say which mode runs")] = False,
    yes: Yes = False,
    timeout: Annotated[
        float, typer.Option("--timeout", callback=positive, help="seconds to wait for each answer")
    ] = 2.0,
) -> None:
    """Release Unitree's locomotion (the motion switcher's ReleaseMode): debug mode, in which the robot obeys
    rt/lowcmd alone. A standing robot falls: hang it first."""
    from .motion_switcher import MotionSwitcher, NoAnswer

    try:
        with MotionSwitcher(interface, domain_id, timeout_s=timeout) as ms:
            mode = ms.check_mode().get("name", "")
            typer.echo(f"mode: {mode or '(none: debug mode)'}")
            if check_only or not mode:
                return
            _confirm(
                yes,
                f"releasing locomotion mode '{mode}' leaves the G1 without balance or posture control: a "
                "standing robot falls. It must hang on its gantry, feet off the ground.",
            )
            for _ in range(5):
                ms.release_mode()
                time.sleep(0.2)
                mode = ms.check_mode().get("name", "")
                if not mode:
                    break
    except (NoAnswer, RuntimeError, ValueError) as e:
        typer.echo(f"error: {e}", err=True)
        raise typer.Exit(1) from None
    if mode:
        typer.echo(f"error: mode '{mode}' still runs after 5 releases", err=True)
        raise typer.Exit(1)
    typer.echo("released: debug mode (rt/lowcmd only; the robot is soft until commanded)")


@app.command()
def stand(
    interface: Interface,
    domain_id: Domain = 0,
    seconds: Annotated[float, typer.Option("--seconds", callback=positive, help="ramp duration")] = 5.0,
    hold: Annotated[
        float, typer.Option("--hold", callback=non_negative, help="seconds to hold home before going soft")
    ] = 2.0,
    yes: Yes = False,
) -> None:
    """Ramp every joint from the current pose to the home pose over --seconds on rt/lowcmd (the driver's
    gains), hold it --hold seconds, then damping. Debug mode only, the robot hanging."""
    from .tools import stand as run_stand

    _confirm(
        yes,
        "stand drives all 29 joints stiffly on rt/lowcmd: the G1 must hang on its gantry in debug mode, "
        "the space around it clear, the remote or emergency stop in hand.",
    )
    try:
        report = run_stand(interface, domain_id, seconds=seconds, hold_s=hold)
    except (ValueError, OSError) as e:
        typer.echo(f"error: {e}", err=True)
        raise typer.Exit(1) from None
    for line in report.lines:
        typer.echo(line)
    if not report.ok:
        typer.echo(f"error: {report.problem}", err=True)
        raise typer.Exit(1)
    typer.echo(f"home reached: largest joint error {report.error:.3f} rad ({report.sent} commands); now damping")
