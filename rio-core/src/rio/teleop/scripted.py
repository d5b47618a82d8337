"""`teleop.scripted`: a teleop device that plays a fixed end-effector script, for headless demos,
CI and tests, through exactly the path a person's device takes (twist + gripper + buttons).

A script is a list of moves, each a displacement of the tool (base frame, m) over a duration, with
a gripper value (0 closed .. 1 open) held during it. The twist of a move follows a raised-cosine
bump (zero at both ends), so a loop that integrates it at any rate lands on the displacement: the
integral of a smooth bump is captured almost exactly even by a coarse sum, and a speed or low-pass
limit never clips a corner. When the last move ends the device presses `BUTTON_DONE`.

The script starts when a control loop calls the `reset()` API (`rio teleop` does at episode
start), so node start-up time never eats into it; until then the device holds still. Besides the
standard keys it publishes `displacement` (rio.interfaces.teleop: its exact motion so far, so a loop
that missed samples, or a device thread stalled between two, loses nothing of the plan; each sample
is stamped with the time the script was read at), `phase` (current move, -1 before the start, n at
the end) and `offset` (the tool displacement of the moves before this one, base frame) so tests can
compare the arm with the plan.

Presets: "pick_place" (above the object, down, grasp, lift, over the place, down, release, back:
the packaged sim scenes put a cube and a pad where its defaults go) and "square" (a horizontal
square and back, gripper untouched).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.teleop import BUTTON_DONE
from rio.interfaces import TeleopNode
from rio.interfaces.teleop import TeleopConfig
from rio.runtime.node import remote


@dataclass(frozen=True)
class Move:
    delta: tuple[float, float, float]
    seconds: float
    gripper: float = 1.0


def _travel(delta, speed: float) -> Move:
    dist = float(np.linalg.norm(delta))
    # a raised cosine peaks at twice its mean speed: 2 * dist / T = speed
    dx, dy, dz = (float(x) for x in delta)
    return Move((dx, dy, dz), max(2.0 * dist / speed, 0.4))


def build_script(cfg: ScriptedTeleopConfig) -> list[Move]:
    if cfg.script == "moves":
        if not cfg.moves:
            raise ValueError("script = 'moves' needs a non-empty `moves` list")
        out = []
        for i, m in enumerate(cfg.moves):
            if len(m) != 5 or m[4] <= 0:
                raise ValueError(f"moves[{i}] must be [dx, dy, dz, gripper, seconds > 0], got {m}")
            out.append(Move((m[0], m[1], m[2]), float(m[4]), float(m[3])))
        return out
    s = cfg.speed
    if cfg.script == "square":
        d = cfg.side
        return [Move((0, 0, 0), 0.3)] + [_travel(v, s) for v in ((d, 0, 0), (0, d, 0), (-d, 0, 0), (0, -d, 0))] \
            + [Move((0, 0, 0), 0.5)]
    p, q, h = np.asarray(cfg.pick), np.asarray(cfg.place), cfg.lift
    closed = 0.0
    script = [
        Move((0, 0, 0), 0.4),
        _travel((p[0], p[1], 0.0), s),
        _travel((0.0, 0.0, p[2]), s),
        Move((0, 0, 0), cfg.grasp_s, closed),
    ]
    up = _travel((0.0, 0.0, h), s)
    over = _travel((q[0] - p[0], q[1] - p[1], 0.0), s)
    down = _travel((0.0, 0.0, q[2] - (p[2] + h)), s)
    script += [Move(m.delta, m.seconds, closed) for m in (up, over, down)]
    script += [
        Move((0, 0, 0), cfg.grasp_s, 1.0),
        _travel((0.0, 0.0, -q[2]), s),
        _travel((-q[0], -q[1], 0.0), s),
        Move((0, 0, 0), 0.5),
    ]
    return script


def bump(tau: float, seconds: float) -> float:
    """Raised-cosine velocity profile with unit integral over [0, seconds]."""
    return (1.0 - math.cos(2.0 * math.pi * tau / seconds)) / seconds


def bump_integral(tau: float, seconds: float) -> float:
    """The integral of `bump` from 0 to `tau`: the fraction of a move done (0 .. 1)."""
    x = min(max(tau / seconds, 0.0), 1.0)
    return x - math.sin(2.0 * math.pi * x) / (2.0 * math.pi)


class ScriptedTeleop(TeleopNode):
    class Config(TeleopConfig):
        script: Literal["pick_place", "square", "moves"] = Field("pick_place", description="preset, or 'moves'")
        pick: list[float] = Field([0.0, 0.06, -0.085], min_length=3, max_length=3,
                                  description="grasp point relative to the start tool position (m, base frame)")
        place: list[float] = Field([0.0, -0.06, -0.08], min_length=3, max_length=3,
                                   description="release point relative to the start tool position (m)")
        lift: float = Field(0.08, ge=0, description="lift above the grasp point before moving over (m)")
        side: float = Field(0.05, gt=0, description="edge of the 'square' preset (m)")
        moves: list[list[float]] = Field(default_factory=list,
                                         description="script='moves': [[dx, dy, dz, gripper, seconds], ...]")
        speed: float = Field(0.08, gt=0, description="peak tool speed (m/s)")
        grasp_s: float = Field(0.8, ge=0, description="time to close or open the gripper (s)")
        rate_hz: float = Field(100.0, gt=0)

    def setup(self) -> None:
        super().setup()
        self.moves = build_script(self.config)
        self.ends = np.cumsum([m.seconds for m in self.moves])
        self.offsets = np.cumsum([m.delta for m in self.moves], axis=0)
        self.example_data = {**self.example_data, "phase": 0, "offset": np.zeros(3), "displacement": np.zeros(6),
                             "timestamp": 0.0}  # stamped by the device: the time the script was read at
        self.t_start: float | None = None
        self.carried = np.zeros(3)  # what the runs before this one moved: the total never jumps

    @remote
    def reset(self) -> float:
        """(Re)start the script now; returns its length in seconds."""
        now = clock.now()
        if self.t_start is not None:
            self.carried = self._moved(now - self.t_start)
        self.t_start = now
        return float(self.ends[-1])

    @remote
    def script_length(self) -> float:
        return float(self.ends[-1])

    def _moved(self, t: float) -> np.ndarray:
        """The displacement (m) `t` s into this run, on top of what the runs before moved."""
        i = int(np.searchsorted(self.ends, t, side="right"))
        if i >= len(self.moves):
            return self.carried + self.offsets[-1]
        move = self.moves[i]
        done = self.offsets[i - 1] if i > 0 else np.zeros(3)
        start = self.ends[i] - move.seconds
        return self.carried + done + np.asarray(move.delta) * bump_integral(t - start, move.seconds)

    def read_state(self) -> dict[str, Any]:
        now = clock.now()  # the one time the sample is of: its twist, its displacement and its stamp
        twist, buttons, moved = np.zeros(6), np.zeros(self.config.buttons, bool), np.zeros(6)
        if self.t_start is None:
            moved[:3] = self.carried
            return {"twist": twist, "gripper": 1.0, "buttons": buttons, "phase": -1, "offset": np.zeros(3),
                    "displacement": moved, "timestamp": now}
        t = now - self.t_start
        moved[:3] = self._moved(t)
        i = int(np.searchsorted(self.ends, t, side="right"))
        if i >= len(self.moves):
            buttons[BUTTON_DONE:BUTTON_DONE + 1] = True  # where the configured buttons include it
            return {"twist": twist, "gripper": self.moves[-1].gripper, "buttons": buttons, "phase": len(self.moves),
                    "offset": self.offsets[-1], "displacement": moved, "timestamp": now}
        move = self.moves[i]
        t0 = self.ends[i] - move.seconds
        twist[:3] = np.asarray(move.delta) * bump(t - t0, move.seconds)
        done = self.offsets[i - 1] if i > 0 else np.zeros(3)
        return {"twist": twist, "gripper": move.gripper, "buttons": buttons, "phase": i, "offset": done,
                "displacement": moved, "timestamp": now}


ScriptedTeleopConfig = ScriptedTeleop.Config
