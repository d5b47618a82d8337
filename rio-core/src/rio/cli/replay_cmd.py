"""`rio replay DATASET --episode K --station STATION`: play recorded actions back at the recorded rate."""

from __future__ import annotations

from typing import Annotated

import typer

from .run_cmd import JsonOption, ProfileOption


def replay(
    dataset: Annotated[str, typer.Argument(help="Native RIO dataset directory.")],
    station: Annotated[str, typer.Option("--station", "-s", help="Station name or .toml path (same morphology).")],
    episode: Annotated[int, typer.Option("--episode", "-e", help="Episode index.")] = 0,
    middleware: Annotated[str | None, typer.Option("--middleware", "-m", help="Use this middleware instead.")] = None,
    speed: Annotated[float, typer.Option("--speed", help="Playback speed (1 = as recorded).")] = 1.0,
    approach_s: Annotated[float, typer.Option("--approach", help="Seconds to move to the first action.")] = 2.0,
    json_out: JsonOption = False,
    profile: ProfileOption = None,
) -> None:
    """Replay an episode's actions on a station (checks the morphology and action layout first)."""
    from ..recording.replay import replay_episode
    from .run_cmd import finish

    summary = replay_episode(dataset, episode, station, middleware=middleware, speed=speed, approach_s=approach_s,
                             profile=profile, log=lambda m: typer.echo(m, err=True))
    finish(summary, json_out)
