"""`rio teleop STATION`: the teleop workflow as a command (typer). Mounted by the CLI; all work is
done by `rio.workflows.teleop.run_teleop`, so scripts and tests call exactly what the command runs."""

from __future__ import annotations

from typing import Annotated

import typer

from rio.cli.args import key_values, one_of, positive
from rio.cli.run_cmd import (
    DurationOption,
    JsonOption,
    MiddlewareOption,
    ProfileOption,
    QuietOption,
    RateOption,
    ReadyTimeoutOption,
    RecordOption,
    SeedOption,
    StationArgument,
    TeleopOption,
    TeleopSetOption,
)


def _mode(value: str | None) -> str | None:
    """--mode is checked while parsing, with the aliases the loop accepts (`2d`, `full`, ...)."""
    from rio.control.teleop import TeleopMode  # here: listing commands must not import numpy

    if value is None:
        return None
    try:
        TeleopMode.parse(value)
    except ValueError as e:
        raise typer.BadParameter(str(e)) from None
    return value


def teleop(
    station: StationArgument,
    device: TeleopOption = None,
    teleop_set: TeleopSetOption = None,
    instruction: Annotated[str | None, typer.Option("--instruction", "-i",
                                                    help="Task text stored with every step.")] = None,
    viz: Annotated[bool, typer.Option("--viz", help="Stream cameras, joints and tool poses to rerun "
                                                    "(saved to an .rrd file when there is no display).")] = False,
    duration: DurationOption = None,
    mode: Annotated[str | None, typer.Option("--mode", callback=_mode,
                                             help="translation (twist devices' default), translation_rotation "
                                                  "(hand trackers' default), planar (2-D) or rotation; the "
                                                  "device's mode button cycles it.")] = None,
    hand: Annotated[str, typer.Option("--hand", callback=one_of("left", "right"),
                                      help="Hand trackers: the hand that drives a single arm.")] = "right",
    scale: Annotated[float, typer.Option("--scale", callback=positive,
                                         help="Hand trackers: tool motion per wrist motion.")] = 1.0,
    max_pos_speed: Annotated[float, typer.Option(callback=positive, help="Tool speed limit (m/s).")] = 0.15,
    max_rot_speed: Annotated[float, typer.Option(callback=positive,
                                                 help="Tool rotation speed limit (rad/s).")] = 1.0,
    rate: RateOption = None,
    middleware: MiddlewareOption = None,
    ready_timeout: ReadyTimeoutOption = None,
    quiet: QuietOption = False,
    record: RecordOption = None,
    seed: SeedOption = None,
    episodes: Annotated[int | None, typer.Option("--episodes", min=1,
                                                 help="With --record: episodes to keep (default 1).")] = None,
    on_end: Annotated[str | None, typer.Option("--on-end", callback=one_of("auto", "ask", "keep", "discard"),
                                               help="With --record, after each run: ask (keys k/d/r in a terminal), "
                                                    "keep or discard. Default: ask when interactive, else keep. A "
                                                    "device's keep/discard button decides without asking.")] = None,
    align_speed: Annotated[float, typer.Option(callback=positive,
                                               help="Leader arms: follower speed while aligning to its leader "
                                                    "(rad/s).")] = 0.5,
    json_out: JsonOption = False,
    profile: ProfileOption = None,
) -> None:
    """Teleoperate a station's arm(s): a twist device in end-effector space, a leader arm joint by joint.
    Prints a summary when it ends."""
    for given, option in ((episodes, "--episodes"), (on_end, "--on-end")):
        if given is not None and record is None:  # it would do nothing: said, not silently ignored
            raise typer.BadParameter("only means something with --record DIR (recording is off)", param_hint=option)
    from rio.cli.run_cmd import finish, shows_status
    from rio.workflows.teleop import prepare_station, run_teleop

    st = prepare_station(station, device, key_values(teleop_set, "--teleop-set"))  # the one load of the run

    def run(recorder=None):
        return run_teleop(st, instruction=instruction, viz=viz,
                          duration=duration, middleware=middleware, rate_hz=rate, mode=mode, hand=hand, scale=scale,
                          max_pos_speed=max_pos_speed, max_rot_speed=max_rot_speed, align_speed=align_speed,
                          recorder=recorder, profile=profile, log=lambda m: typer.echo(m, err=True), seed=seed,
                          ready_timeout=ready_timeout,
                          status=shows_status(quiet, json_out))

    if record is None:
        finish(run(), json_out)
        return
    finish(_record_episodes(run, record, episodes or 1, on_end or "auto", st, instruction, rate, json_out), json_out,
           printed=True)


def _record_episodes(run, root: str, episodes: int, on_end: str, st, instruction: str | None,
                     rate: float | None, json_out: bool):
    """One teleop run per episode; after each, keep / discard / re-record: the device's keep or discard
    button when the run ended on one, else a key in a terminal, or the --on-end choice for headless
    runs. The recorder makes every kept episode durable at once.
    A run ended by a signal is kept (headless) and ends the session; so does a run in which a node stopped,
    faulted or was stopped (its summary's events). Returns the last run's summary."""
    import sys

    from rio.recording import Recorder, station_depth

    ask = on_end == "ask" or (on_end == "auto" and sys.stdin.isatty())
    with Recorder(root, fps=rate or st.rate_hz, station=st.name, instruction=instruction, cameras=st.has_cameras,
                  depth=station_depth(st), episodes=episodes) as rec:
        while not rec.done:
            summary = run(recorder=rec)
            if not json_out:
                typer.echo(summary.format())
            said = summary.details.get("verdict") if not summary.signal else None  # the device's button
            if said:
                choice = said[:1]
            elif ask and not summary.signal:
                choice = typer.prompt(f"{rec.status()}: [k]eep, [d]iscard or [r]e-record?", default="k")[:1]
            else:
                choice = (on_end if on_end not in ("auto", "ask") else "keep")[:1]
            if choice.lower() == "k":
                meta = rec.keep()
                typer.echo(f"kept episode {meta['index'] if meta else '(empty, dropped)'} in {root}", err=True)
            else:
                rec.discard()
                typer.echo("discarded" if choice == "d" else "discarded; recording it again", err=True)
                if choice == "d" and not ask and not said:
                    break  # headless discard: do not loop forever
            if summary.signal or summary.problem:  # stopped, or a node went wrong: the session ends here
                break
    typer.echo(f"dataset {root}: {len(rec.kept)} episode(s) kept", err=json_out)  # --json: stdout is the JSON
    return summary
