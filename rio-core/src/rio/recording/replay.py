"""`rio replay`: play a recorded episode's actions back on any station of the same morphology.

Written against `make_station` and `Env` only, so it runs on simulated and real stations and any
middleware. The robot first moves to the episode's first action over `approach_s` seconds (never a
jump), then every action is sent at its recorded time (scaled by `speed`), each with the next
action's time as its target, so drivers interpolate exactly as during recording.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import clock
from ..errors import RioError
from .dataset import Dataset


@dataclass
class ReplaySummary:
    episode: int
    station: str
    steps: int = 0
    seconds: float = 0.0
    recorded_seconds: float = 0.0
    late_ticks: int = 0
    max_late_ms: float = 0.0
    #: max |proprio - last action| once the robot settled (same units as the action)
    final_error: float = float("nan")
    notes: list[str] = field(default_factory=list)


def check_compatible(meta: dict[str, Any], env: Any, action_dim: int) -> None:
    """Refuse a station whose morphology or action layout differs from the recording's."""
    robot = env.robot
    emb = meta.get("embodiment")
    if emb is not None and emb != robot.name:
        raise RioError(f"the episode was recorded on a '{emb}' embodiment; station '{env.station}' is '{robot.name}'")
    if action_dim != env.action_dim:
        raise RioError(f"the episode's actions have {action_dim} values; station '{env.station}' takes "
                       f"{env.action_dim}: {robot.describe_action()}")
    layout = meta.get("action_parts")
    if layout is not None and [list(x) for x in robot.action_parts()] != [list(x) for x in layout]:
        raise RioError(f"action layout differs: recorded {layout}, station has {robot.action_parts()}")


def replay_episode(dataset: Any, episode: int, station: Any, *, middleware: str | None = None, speed: float = 1.0,
                   approach_s: float = 2.0, on_step: Callable[[int, Any], None] | None = None,
                   log: Callable[[str], None] | None = print) -> ReplaySummary:
    from ..manager import ServerManager
    from ..station.build import make_station
    from ..station.load import load_station

    say = log or (lambda _m: None)
    if speed <= 0:
        raise ValueError("speed must be > 0")
    ep = (dataset if isinstance(dataset, Dataset) else Dataset(dataset)).episode(episode)
    if "action" not in ep.schema.names:
        raise RioError(f"episode {episode} recorded no actions; nothing to replay")
    actions, t = ep.column("action").astype(np.float64), ep.column("t")
    valid = np.isfinite(actions).all(axis=1)
    actions, t = actions[valid], t[valid]
    if len(actions) == 0:
        raise RioError(f"episode {episode} has no complete action")
    st = load_station(station)
    servers, _clients, env = make_station(st, middleware=middleware)
    if env is None:
        raise RioError(f"station '{st.name}' has no arm or humanoid to replay on")
    summary = ReplaySummary(episode, st.name, recorded_seconds=float(t[-1] - t[0]) + 1.0 / ep.fps)
    if not valid.all():
        summary.notes.append(f"{int((~valid).sum())} steps without an action skipped")
    with ServerManager(servers, station=st.name), env:
        check_compatible(ep.meta, env, actions.shape[1])
        env.reset()
        if approach_s > 0:
            say(f"moving to the episode's first action over {approach_s:g} s ...")
            t_arrive = clock.now() + approach_s
            env.step(actions[0], t_cmd_target=t_arrive)
            clock.precise_wait(t_arrive + 0.1)
        say(f"replaying episode {episode}: {len(actions)} actions over {summary.recorded_seconds / speed:.1f} s")
        rel = (t - t[0]) / speed
        period = 1.0 / (ep.fps * speed)
        t0 = clock.now()
        for i, a in enumerate(actions):
            clock.precise_wait(t0 + rel[i])
            late = clock.now() - (t0 + rel[i])
            if late > period / 2:
                summary.late_ticks += 1
            summary.max_late_ms = max(summary.max_late_ms, late * 1000)
            t_next = t0 + (rel[i + 1] if i + 1 < len(rel) else rel[i] + period)
            step = env.step(a, t_cmd_target=t_next)
            summary.steps += 1
            if on_step is not None:
                on_step(i, step)
        summary.seconds = clock.now() - t0
        clock.precise_wait(clock.now() + max(3 * period, 0.1))
        final = env.get_state().observation.proprio
        if final.shape == actions[-1].shape:
            summary.final_error = float(np.max(np.abs(final - actions[-1])))
    return summary
