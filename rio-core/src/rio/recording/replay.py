"""`rio replay`: play a recorded episode's actions back on any station of the same morphology.

Written against `make_station` and `Env` only, so it runs on simulated and real stations and any
middleware. The robot first moves to the episode's first action over `approach_s` seconds (never a
jump), then `EpisodeReplay` runs on the one control loop at the recording's rate (times `speed`):
each tick commands the recorded action trajectory at the tick's target time, each action meeting
the time it was recorded for, so drivers interpolate exactly as during recording. A damaged episode
(files differing from their recorded sha256) is refused before the robot moves, unless `allow_damaged`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rio import clock
from rio.errors import ConfigError, RioError
from rio.loop.control_loop import Tick
from rio.loop.summary import RunSummary
from rio.recording.dataset import Dataset, Episode


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


class EpisodeReplay:
    """Controller (rio.loop.control_loop): a recorded episode's actions, interpolated at each tick's target.

    Action i of the recording was the command for the i-th tick's target; here it is due at
    `(t[i] - t[0]) / speed` after the first tick's target, and a tick between two of them gets the
    straight line between both (the drivers interpolate the same way)."""

    name = "replay"

    def __init__(self, actions: np.ndarray, t: np.ndarray, fps: float, *, speed: float = 1.0,
                 approach_s: float = 2.0, episode: int = 0):
        self.actions, self.speed, self.approach_s, self.episode = actions, float(speed), float(approach_s), episode
        self.rel = (t - t[0]) / self.speed
        self.due = self.rel
        self.recorded_seconds = float(t[-1] - t[0]) + 1.0 / fps
        self.sent = 0
        self.finished = False

    def reset(self, loop: Any) -> None:
        self.due = self.rel + loop.dt + loop.lead_s  # the first tick's target (rio.loop.control_loop's timing)
        if self.approach_s > 0:
            loop.say(f"moving to the episode's first action over {self.approach_s:g} s ...")
            t_arrive = clock.now() + self.approach_s
            loop.env.step(self.actions[0], t_cmd_target=t_arrive)
            clock.precise_wait(t_arrive + 0.1)
        loop.say(f"replaying episode {self.episode}: {len(self.actions)} actions over "
                 f"{self.recorded_seconds / self.speed:.1f} s")

    def step(self, tick: Tick) -> np.ndarray:
        rel = tick.t_target - tick.t0
        i = int(np.searchsorted(self.due, rel + 1e-9, side="right"))  # actions due by the target time
        self.sent = max(self.sent, i)
        if i >= len(self.due):
            self.finished = True
            return self.actions[-1]
        if i == 0:
            return self.actions[0]
        w = (rel - self.due[i - 1]) / (self.due[i] - self.due[i - 1])
        return self.actions[i - 1] + w * (self.actions[i] - self.actions[i - 1])

    def done(self) -> str | None:
        return "the episode ended" if self.finished else None

    def finish(self, summary: RunSummary) -> None:
        summary.details.update(episode=self.episode, actions=len(self.actions),
                               recorded_seconds=self.recorded_seconds, speed=self.speed)
        summary.lines.append(f"episode {self.episode}: {len(self.actions)} actions recorded over "
                             f"{self.recorded_seconds:.1f} s, replayed at speed {self.speed:g}")


def check_timing(speed: float, approach_s: float) -> None:
    """Refuse a speed or approach time the loop cannot run at (0, negative, NaN, infinite)."""
    if not (math.isfinite(speed) and speed > 0):
        raise ConfigError(f"replay speed must be a finite number > 0 (got {speed:g})")
    if not (math.isfinite(approach_s) and approach_s >= 0):
        raise ConfigError(f"approach time must be a finite number of seconds >= 0 (got {approach_s:g})")


def open_episode(dataset: Any, episode: int, allow_damaged: bool = False) -> Episode:
    """The episode to replay, verified: a damaged one raises DamagedEpisode (unless allowed)."""
    ds = dataset if isinstance(dataset, Dataset) else Dataset(dataset)
    ep = ds.episode(episode)
    ep.allow_damaged = ep.allow_damaged or allow_damaged
    ep.check()
    return ep
