"""`rio teleop STATION`: the teleop workflow as a command (typer). Mounted by the CLI; all work is
done by `rio.workflows.teleop.run_teleop`, so scripts and tests call exactly what the command runs."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from rio.cli.args import key_values, non_negative, one_of, positive
from rio.cli.home_cmd import HOME_SPEED, HomeOption, HomeSpeedOption, YesOption, confirm_homing
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
                                               help="With --record, after each run: ask (a single key in a "
                                                    "terminal: y keep, n discard, e re-record), keep or discard. "
                                                    "Default: ask when interactive, else keep. A device's "
                                                    "keep/discard button decides without asking.")] = None,
    reset_s: Annotated[float, typer.Option("--reset-time", callback=non_negative, metavar="SECONDS",
                                           help="With --record --episodes: seconds between episodes, counted "
                                                "down while the scene resets (the station keeps running).")] = 3.0,
    home: HomeOption = False,
    home_speed: HomeSpeedOption = HOME_SPEED,
    yes: YesOption = False,
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
    from rio.workflows.teleop import prepare_station, record_teleop, run_teleop

    st = prepare_station(station, device, key_values(teleop_set, "--teleop-set"))  # the one load of the run
    speed = confirm_homing(st, home_speed, yes) if home else None
    common: dict[str, Any] = dict(viz=viz, mode=mode, hand=hand, scale=scale, max_pos_speed=max_pos_speed,
                                  max_rot_speed=max_rot_speed, align_speed=align_speed)
    session: dict[str, Any] = dict(duration=duration, middleware=middleware, rate_hz=rate, instruction=instruction,
                                   profile=profile, log=lambda m: typer.echo(m, err=True), seed=seed,
                                   ready_timeout=ready_timeout, status=shows_status(quiet, json_out),
                                   home_speed=speed)
    if record is None:
        finish(run_teleop(st, **common, **session), json_out)
        return
    finish(record_episodes(lambda rec, decide: record_teleop(st, rec, decide, **common, **session, reset_s=reset_s),
                           record, episodes or 1, on_end or "auto", st, instruction, rate, json_out), json_out,
           printed=True)


#: The single keys of the prompt between episodes: none is a key of the keyboard teleop (w/s a/d r/f i/k j/l u/o,
#: space, m, q), so a key pressed a moment too late for the teleop never decides an episode.
KEYS = {"y": "keep", "n": "discard", "e": "rerecord"}


def decider(on_end: str, ask: bool, json_out: bool, read: Any = None) -> Any:
    """`decide(summary, recorder, stop) -> (choice, go on)` for `record_session`: the device's keep or discard button
    when the run ended on one; else a single key when `ask` (`read(stopped)`: `rio.cli.keypress.read_key`), even
    after Ctrl+C; else the --on-end choice, keep by default (a signal: kept, and said). A headless discard ends
    the session (it would loop forever); a signal always does."""
    from rio.cli.keypress import read_key

    def decide(summary: Any, rec: Any, stop: Any = None) -> tuple[str, bool]:
        choice, go_on = choose(summary, rec, stop)
        return choice, go_on and not summary.problem  # a node stopped, faulted or was stopped: the session ends

    def choose(summary: Any, rec: Any, stop: Any = None) -> tuple[str, bool]:
        if not json_out:
            typer.echo(summary.format())
        said = summary.details.get("verdict") if not summary.signal else None  # the device's button
        if said:
            return ("keep" if said == "keep" else "discard"), True
        if ask:
            why = f" (stopped by {summary.signal})" if summary.signal else ""
            typer.echo(f"{rec.status()}{why}: [y] keep, [n] discard, [e] re-record? ", err=True, nl=False)
            # a first signal at the prompt: no answer; after one (it ended the run) a second raises Ctrl+C's
            stopped = (lambda: False) if summary.signal or stop is None else (lambda: stop.received is not None)
            key = (read or (lambda s: read_key(KEYS, stopped=s)))(stopped)
            typer.echo(key or "", err=True)
            if key is None:
                typer.echo("no answer (stopped): the episode is kept", err=True)
                return "keep", False
            return KEYS[key], not summary.signal
        if summary.signal:
            typer.echo(f"stopped by {summary.signal} without a terminal to ask: the episode is kept", err=True)
            return "keep", False
        choice = on_end if on_end in ("keep", "discard") else "keep"
        return choice, choice == "keep"

    return decide


def record_episodes(session: Any, root: str, episodes: int, on_end: str, st: Any, instruction: str | None,
                    rate: float | None, json_out: bool, read: Any = None) -> Any:
    """Record `episodes` episodes into `root` in one station session (`session(recorder, decide)`: the workflow,
    `record_teleop`); after each, keep / discard / re-record (`decider`). The recorder makes every kept episode
    durable at once. Returns the last run's summary."""
    import sys

    from rio.recording import Recorder, station_depth

    ask = on_end == "ask" or (on_end == "auto" and sys.stdin.isatty())
    with Recorder(root, fps=rate or st.rate_hz, station=st.name, instruction=instruction, cameras=st.has_cameras,
                  depth=station_depth(st), episodes=episodes) as rec:
        summary = session(rec, decider(on_end, ask, json_out, read))
    typer.echo(f"dataset {root}: {len(rec.kept)} episode(s) kept", err=json_out)  # --json: stdout is the JSON
    return summary
