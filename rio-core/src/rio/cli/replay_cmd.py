"""`rio replay DATASET --episode K --station STATION`: play recorded actions back at the recorded rate."""

from __future__ import annotations

from typing import Annotated

import typer


def replay(
    dataset: Annotated[str, typer.Argument(help="Native RIO dataset directory.")],
    station: Annotated[str, typer.Option("--station", "-s", help="Station name or .toml path (same morphology).")],
    episode: Annotated[int, typer.Option("--episode", "-e", help="Episode index.")] = 0,
    middleware: Annotated[str | None, typer.Option("--middleware", "-m", help="Use this middleware instead.")] = None,
    speed: Annotated[float, typer.Option("--speed", help="Playback speed (1 = as recorded).")] = 1.0,
    approach_s: Annotated[float, typer.Option("--approach", help="Seconds to move to the first action.")] = 2.0,
) -> None:
    """Replay an episode's actions on a station (checks the morphology and action layout first)."""
    from ..recording.replay import replay_episode
    from .output import console

    s = replay_episode(dataset, episode, station, middleware=middleware, speed=speed, approach_s=approach_s,
                       log=lambda m: console(stderr=True).print(m, markup=False))
    console().print(f"replayed episode {s.episode} on '{s.station}': {s.steps} actions in {s.seconds:.2f} s "
                    f"(recorded {s.recorded_seconds:.2f} s), {s.late_ticks} late ticks (max {s.max_late_ms:.1f} ms), "
                    f"final error {s.final_error:.4g}", markup=False)
    for n in s.notes:
        console().print(f"note: {n}", markup=False)
