"""`rio replay DATASET --episode K --station STATION`: play recorded actions back at the recorded rate.

A damaged episode (a file differing from its recorded sha256) is refused before the robot moves;
`--allow-damaged` replays it anyway, with a warning."""

from __future__ import annotations

from typing import Annotated

import typer

from rio.cli.args import known_station, non_negative, not_empty, positive
from rio.cli.home_cmd import HOME_SPEED, HomeOption, HomeSpeedOption, YesOption, confirm_homing
from rio.cli.run_cmd import JsonOption, MiddlewareOption, ProfileOption, QuietOption, ReadyTimeoutOption, shows_status


def replay(
    dataset: Annotated[str, typer.Argument(callback=not_empty, help="Native RIO dataset directory.")],
    station: Annotated[str, typer.Option("--station", "-s", callback=known_station,
                                         help="Station name or .toml path (same morphology).")],
    episode: Annotated[int, typer.Option("--episode", "-e", min=0, help="Episode index.")] = 0,
    middleware: MiddlewareOption = None,
    speed: Annotated[float, typer.Option("--speed", callback=positive,
                                         help="Playback speed (1 = as recorded).")] = 1.0,
    approach_s: Annotated[float, typer.Option("--approach", callback=non_negative,
                                              help="Seconds to move to the first action.")] = 2.0,
    allow_damaged: Annotated[bool, typer.Option("--allow-damaged",
                                                help="Replay an episode whose files fail their sha256.")] = False,
    ready_timeout: ReadyTimeoutOption = None,
    quiet: QuietOption = False,
    home: HomeOption = False,
    home_speed: HomeSpeedOption = HOME_SPEED,
    yes: YesOption = False,
    json_out: JsonOption = False,
    profile: ProfileOption = None,
) -> None:
    """Replay an episode's actions on a station (checks the morphology and action layout first)."""
    from rio.cli.datasets_cmd import damaged_warnings
    from rio.cli.run_cmd import finish
    from rio.recording import Dataset
    from rio.station.load import load_station
    from rio.workflows.replay import replay_episode

    speed_home = confirm_homing(load_station(station), home_speed, yes) if home else None
    with damaged_warnings():
        summary = replay_episode(Dataset(dataset, allow_damaged=allow_damaged), episode, station,
                                 middleware=middleware, speed=speed, approach_s=approach_s, profile=profile,
                                 log=lambda m: typer.echo(m, err=True), ready_timeout=ready_timeout,
                                 status=shows_status(quiet, json_out), home_speed=speed_home)
    finish(summary, json_out)
