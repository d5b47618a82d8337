"""The command timeline built from action chunks: latency compensation and blending (pure numpy).

Each chunk is placed on the time axis by the time of the observation it was computed from
(`ActionChunk.times()`), not by when it arrived, so a chunk that took 90 ms to compute is used from
its action for *now* on: the actions already in the past are dropped (latency compensation). Where a
new chunk overlaps what is still scheduled, the overlap is blended:

- `latest`: the new chunk takes over at once (from its arrival time);
- `crossfade`: linear cross-fade from the previous command to the new chunk over `crossfade_s` (or
  until the previous chunk ends, if sooner);
- `ensemble`: temporal ensembling as in ACT (Zhao et al., 2023): the mean of every chunk that covers
  the time, weighted `exp(-decay * k)` with k = 0 for the oldest (decay < 0 favours newer chunks).

`sample(t)` gives the command for any time `t`, linearly interpolated between a chunk's actions
(`rio.control.Waypoints`), so a loop may run at any rate. Past the newest chunk's last action the
policy is late: the schedule holds its last command (`on_late="hold"`) or continues along the
chunk's final velocity for at most `max_continue_s` before holding (`"continue"`).
Time is passed in, so every rule here is checked numerically in tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rio.control.interpolators import Waypoints
from rio.policy.base import ActionChunk

BlendMode = Literal["latest", "crossfade", "ensemble"]
LateMode = Literal["hold", "continue"]


@dataclass
class ScheduleConfig:
    blend: BlendMode = "crossfade"
    crossfade_s: float = 0.1
    ensemble_decay: float = 0.01
    on_late: LateMode = "hold"
    max_continue_s: float = 0.25

    def __post_init__(self) -> None:
        if self.blend not in ("latest", "crossfade", "ensemble"):
            raise ValueError(f"blend must be latest, crossfade or ensemble, got {self.blend!r}")
        if self.on_late not in ("hold", "continue"):
            raise ValueError(f"on_late must be hold or continue, got {self.on_late!r}")


class _Placed:
    """One chunk on the time axis, used from `t_from` (its arrival) to its last action's time."""

    def __init__(self, chunk: ActionChunk, t_from: float):
        self.chunk, self.t_from = chunk, float(t_from)
        times = chunk.times()
        self.path = Waypoints(times, chunk.actions) if len(times) > 1 else None
        self.t_end = float(times[-1])
        self.last = chunk.actions[-1]
        self.velocity = (chunk.actions[-1] - chunk.actions[-2]) / chunk.dt if len(times) > 1 else 0.0 * self.last

    def sample(self, t: float) -> np.ndarray:
        return self.path.sample(t) if self.path is not None else self.last.copy()


@dataclass
class Sample:
    """A command and where it came from: the newest chunk contributing to it (`seq`, `t_obs`)."""

    action: np.ndarray
    seq: int
    t_obs: float
    late: bool


class ChunkSchedule:
    def __init__(self, config: ScheduleConfig | None = None):
        self.config = config or ScheduleConfig()
        self.placed: list[_Placed] = []

    def __bool__(self) -> bool:
        return bool(self.placed)

    def add(self, chunk: ActionChunk, t_now: float) -> int:
        """Schedule `chunk`, arrived at `t_now`; returns how many of its actions were already past."""
        p = _Placed(chunk, t_now)
        self.placed.append(p)
        self._prune(t_now)
        return int(np.sum(chunk.times() < t_now))

    def end_time(self) -> float:
        return self.placed[-1].t_end if self.placed else -math.inf

    def remaining(self, t: float) -> int:
        """Actions of the newest chunk still ahead of `t`."""
        if not self.placed:
            return 0
        return int(np.sum(self.placed[-1].chunk.times() > t))

    def sample(self, t: float) -> Sample | None:
        """The command for time `t`, or None before the first chunk."""
        if not self.placed:
            return None
        newest = self.placed[-1]
        late = t > newest.t_end
        if late:
            t_eval = newest.t_end
            base = self._blend(t_eval)
            if self.config.on_late == "continue":
                base = base + newest.velocity * min(t - t_eval, self.config.max_continue_s)
            return Sample(base, newest.chunk.seq, newest.chunk.t_obs, True)
        return Sample(self._blend(t), newest.chunk.seq, newest.chunk.t_obs, False)

    # -- blending -----------------------------------------------------------------------------------
    def _live(self, t: float) -> list[_Placed]:
        return [p for p in self.placed if p.t_from <= t] or self.placed[-1:]

    def _blend(self, t: float) -> np.ndarray:
        live = self._live(t)
        mode = self.config.blend
        if mode == "ensemble":
            covering = [p for p in live if t <= p.t_end] or live[-1:]
            w = np.exp(-self.config.ensemble_decay * np.arange(len(covering)))
            return sum(wk * p.sample(t) for wk, p in zip(w, covering, strict=True)) / float(w.sum())
        value = live[0].sample(t)
        for prev, p in zip(live[:-1], live[1:], strict=True):
            # the fade ends by the time the previous chunk runs out, so it never blends in a held value
            fade = 0.0 if mode == "latest" else min(self.config.crossfade_s, prev.t_end - p.t_from)
            a = 1.0 if fade <= 0 else min(max((t - p.t_from) / fade, 0.0), 1.0)
            value = (1.0 - a) * value + a * p.sample(t)
        return value

    def _prune(self, t: float) -> None:
        """Forget chunks that can no longer contribute at any time >= t."""
        cfg = self.config
        if cfg.blend == "ensemble":
            keep = [p for p in self.placed[:-1] if p.t_end >= t]
            self.placed = keep + self.placed[-1:]
            return
        fade = 0.0 if cfg.blend == "latest" else cfg.crossfade_s
        # the newest chunk whose fade-in is complete by t hides everything older
        for i in range(len(self.placed) - 1, 0, -1):
            if self.placed[i].t_from + fade <= t:
                self.placed = self.placed[i:]
                return
