"""`replay_episode`: play a recorded episode's actions back on any station of the same morphology, on the
one control loop (`rio.recording.replay.EpisodeReplay`). An episode recorded on a station with a task is
replayed from the same start: its seed and episode number (episode.json's `metadata.task`) are passed on."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from rio.errors import RioError
from rio.loop.control_loop import Tick
from rio.loop.summary import RunSummary
from rio.recording.replay import EpisodeReplay, check_compatible, check_timing, open_episode


def replay_episode(dataset: Any, episode: int, station: Any, *, middleware: str | None = None, speed: float = 1.0,
                   approach_s: float = 2.0, on_tick: Callable[[Tick], None] | None = None, profile: str | None = None,
                   log: Callable[[str], None] | None = print, allow_damaged: bool = False,
                   ready_timeout: float | None = None, status: bool = False,
                   home_speed: float | None = None) -> RunSummary:
    from rio.workflows.run import run_workflow

    check_timing(speed, approach_s)
    ep = open_episode(dataset, episode, allow_damaged)
    if "action" not in ep.schema.names:
        raise RioError(f"episode {episode} recorded no actions; nothing to replay")
    actions, t = ep.column("action").astype(np.float64), ep.column("t")
    valid = np.isfinite(actions).all(axis=1)
    actions, t = actions[valid], t[valid]
    if len(actions) == 0:
        raise RioError(f"episode {episode} has no complete action")

    def make(session: Any) -> EpisodeReplay:
        check_compatible(ep.meta, session.env, actions.shape[1])
        return EpisodeReplay(actions, t, ep.fps, speed=speed, approach_s=approach_s, episode=episode)

    task = (ep.meta.get("metadata") or {}).get("task") or {}  # the recording's task episode: the same start
    summary = run_workflow(station, make, middleware=middleware, rate_hz=ep.fps * speed, on_tick=on_tick,
                           profile=profile, log=log, seed=task.get("seed"), episode=task.get("episode"),
                           ready_timeout=ready_timeout, status=status, home_speed=home_speed)
    if not valid.all():
        summary.warnings.append(f"{int((~valid).sum())} steps without an action skipped")
    return summary
