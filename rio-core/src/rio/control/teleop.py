"""Teleoperation mappings: from a device's twist to an end-effector target, the same for every arm.

The paper's relative end-effector teleop: each control tick the device's twist (base frame, m/s and
rad/s) is masked by the current `TeleopMode`, limited to `max_pos_speed` / `max_rot_speed`, and
integrated into the *target* pose (not the measured one, so a slow arm does not make the target
creep back, and releasing the device stops the target exactly where it is).

Button conventions for `rio.interfaces.TeleopNode` devices (indices into `buttons`):
`BUTTON_MODE` cycles the teleop mode, `BUTTON_DONE` ends the episode; a device that can also say what
becomes of the episode sets `BUTTON_KEEP` or `BUTTON_DISCARD` with `BUTTON_DONE` (`rio teleop --record`
then keeps or discards it without asking). Gripper values from devices
are 0 (closed) .. 1 (open); `gripper_opening` turns one into meters for a `GripperNode`.
"""

from __future__ import annotations

import enum

import numpy as np

from rio.control.se3 import apply_twist, as_pose

BUTTON_MODE = 0
BUTTON_DONE = 1
BUTTON_KEEP = 2
BUTTON_DISCARD = 3


def episode_verdict(buttons) -> str | None:
    """'keep' or 'discard' when a device ends the episode with that button held, else None (discard
    wins when both are: keeping a bad demonstration costs more than recording it again)."""
    b = np.asarray(buttons, dtype=bool).reshape(-1)
    if b.size <= BUTTON_DONE or not b[BUTTON_DONE]:
        return None
    if b.size > BUTTON_DISCARD and b[BUTTON_DISCARD]:
        return "discard"
    return "keep" if b.size > BUTTON_KEEP and b[BUTTON_KEEP] else None


class EpisodeEnd:
    """Whether a device has ended the episode (`BUTTON_DONE`) and what it said of it, over a run: the
    part every teleop controller shares (`done()` and `finish()` of rio.loop.control_loop's protocol)."""

    def __init__(self) -> None:
        self.finished = False
        self.verdict: str | None = None

    def update(self, buttons) -> None:
        b = np.asarray(buttons, dtype=bool).reshape(-1)
        self.finished |= bool(b.size > BUTTON_DONE and b[BUTTON_DONE])
        self.verdict = self.verdict or episode_verdict(b)

    def reason(self) -> str | None:
        return "the device finished" if self.finished else None

    def report(self, summary) -> None:
        if self.verdict is not None:
            summary.details["verdict"] = self.verdict
            summary.lines.append(f"the device said: {self.verdict} this episode")


class TeleopMode(enum.IntEnum):
    TRANSLATION = 0           # x, y, z
    TRANSLATION_ROTATION = 1  # all six
    PLANAR = 2                # x, y only (2-D: tabletop pushing)
    ROTATION = 3              # orientation only, the tool point stays put
    BASE = 4                  # the mobile base: x, y and yaw drive its body twist; the arm holds

    @classmethod
    def parse(cls, name: str | int | TeleopMode) -> TeleopMode:
        if isinstance(name, (int, TeleopMode)):
            return cls(int(name))
        key = str(name).strip().upper().replace("-", "_").replace("+", "_").replace(" ", "_")
        aliases = {"2D": "PLANAR", "2_D": "PLANAR", "XYZ": "TRANSLATION", "POS": "TRANSLATION",
                   "POSE": "TRANSLATION_ROTATION", "FULL": "TRANSLATION_ROTATION", "ROT": "ROTATION",
                   "TRANSLATION_AND_ROTATION": "TRANSLATION_ROTATION", "DRIVE": "BASE", "MOBILE": "BASE"}
        key = aliases.get(key, key)
        if key not in cls.__members__:
            raise ValueError(f"unknown teleop mode {name!r}; modes: {', '.join(m.name.lower() for m in cls)}")
        return cls[key]

    def next(self) -> TeleopMode:
        members = list(type(self))
        return members[(members.index(self) + 1) % len(members)]


MODE_MASKS: dict[TeleopMode, np.ndarray] = {
    TeleopMode.TRANSLATION: np.array([1, 1, 1, 0, 0, 0], dtype=np.float64),
    TeleopMode.TRANSLATION_ROTATION: np.ones(6),
    TeleopMode.PLANAR: np.array([1, 1, 0, 0, 0, 0], dtype=np.float64),
    TeleopMode.ROTATION: np.array([0, 0, 0, 1, 1, 1], dtype=np.float64),
    TeleopMode.BASE: np.zeros(6),  # the device drives the base (`base_twist`), not the tool
}

#: The modes of a station without a mobile base (BASE drives nothing there).
ARM_MODES = tuple(m for m in TeleopMode if m != TeleopMode.BASE)


def base_twist(twist, mode: TeleopMode, max_speed: float, max_rot_speed: float) -> np.ndarray:
    """A mobile base's body twist `[vx, vy, wz]` from a device's twist in `mode`: its x, y (m/s) and yaw rate
    (rad/s), speed-limited, in BASE mode; zero in every arm mode (the base stops while the arm is driven)."""
    if TeleopMode(mode) != TeleopMode.BASE:
        return np.zeros(3)
    tw = limit_twist(np.asarray(twist, dtype=np.float64).reshape(6) * [1, 1, 0, 0, 0, 1], max_speed, max_rot_speed)
    return tw[[0, 1, 5]]


def mask_twist(twist, mode: TeleopMode) -> np.ndarray:
    return np.asarray(twist, dtype=np.float64).reshape(6) * MODE_MASKS[TeleopMode(mode)]


def limit_twist(twist, max_pos_speed: float, max_rot_speed: float) -> np.ndarray:
    """Scale the linear and angular parts down (direction kept) to at most the given speeds."""
    tw = np.asarray(twist, dtype=np.float64).reshape(6).copy()
    for part, limit in ((slice(0, 3), max_pos_speed), (slice(3, 6), max_rot_speed)):
        n = float(np.linalg.norm(tw[part]))
        if n > limit:
            tw[part] *= (limit / n) if limit > 0 else 0.0
    return tw


def make_teleop_eef_cmd(target_pose, twist, dt: float, mode: TeleopMode, max_pos_speed: float,
                        max_rot_speed: float, workspace: tuple | None = None) -> np.ndarray:
    """The next end-effector target: `target_pose` moved by the masked, speed-limited twist over dt.
    `workspace=(lo, hi)` (two 3-vectors, base frame) clamps the target position."""
    tw = limit_twist(mask_twist(twist, mode), max_pos_speed, max_rot_speed)
    out = apply_twist(as_pose(target_pose), tw, dt)
    if workspace is not None:
        lo, hi = (np.asarray(w, dtype=np.float64) for w in workspace)
        out[:3] = np.clip(out[:3], lo, hi)
    return out


def gripper_opening(value: float, max_width: float) -> float:
    """Device gripper value (0 closed .. 1 open) -> opening in meters."""
    return float(min(max(value, 0.0), 1.0)) * float(max_width)


class ButtonEdges:
    """Rising edges of a button array: a held button fires once, not every tick."""

    def __init__(self) -> None:
        self._prev: np.ndarray | None = None

    def __call__(self, buttons) -> np.ndarray:
        b = np.asarray(buttons, dtype=bool).reshape(-1)
        prev = self._prev if self._prev is not None and self._prev.shape == b.shape else np.zeros_like(b)
        self._prev = b.copy()
        return b & ~prev

    def pressed(self, buttons, index: int) -> bool:
        edges = self(buttons)
        return bool(index < edges.size and edges[index])


class ModeSwitch:
    """Cycles the teleop mode on presses of `BUTTON_MODE` through `modes` (default: every arm mode; a
    station with a mobile base adds BASE, so the same key switches the axes between the arm and the base),
    ignoring presses closer than `debounce_s` to the last change (the paper's `t_last_mode_change`)."""

    def __init__(self, mode: TeleopMode = TeleopMode.TRANSLATION, debounce_s: float = 0.3,
                 modes: tuple[TeleopMode, ...] = ARM_MODES):
        self.mode, self.debounce_s = TeleopMode(mode), float(debounce_s)
        self.modes = tuple(modes)
        self.t_last_change = -np.inf

    def update(self, pressed: bool, t: float) -> TeleopMode:
        if pressed and t - self.t_last_change >= self.debounce_s:
            i = self.modes.index(self.mode) if self.mode in self.modes else -1
            self.mode, self.t_last_change = self.modes[(i + 1) % len(self.modes)], float(t)
        return self.mode
