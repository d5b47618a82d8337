"""Fake teleop devices: a twist device that holds still and a scripted headset hand tracker."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio import interfaces as ifc
from rio.runtime.node import remote


class FakeTeleop(ifc.TeleopNode):
    """A teleop device held still: publishes a constant twist, gripper command and released buttons."""

    class Config(ifc.TeleopNode.Config):
        twist: list[float] = Field(default_factory=lambda: [0.0] * 6, min_length=6, max_length=6,
                                   description="constant twist published (m/s, rad/s)")
        gripper: float = Field(1.0, ge=0, le=1, description="0 closed .. 1 open")
        pressed: list[int] = Field(default_factory=list, description="indices of the buttons held from the "
                                                                     "start (1 + 2: done, keep the episode)")
        pressed_runs: list[list[int]] | None = Field(None, description="the buttons held in each run instead "
                                                                       "(a run starts at `reset()`; past the "
                                                                       "list, its last): a recording session")

    def setup(self) -> None:
        super().setup()
        self.run = 0  # how many runs have started (`reset()` calls)

    @remote
    def reset(self) -> float:
        self.run += 1
        return 0.0

    def read_state(self) -> dict[str, Any]:
        buttons = np.zeros(self.config.buttons, bool)
        runs = self.config.pressed_runs
        pressed = self.config.pressed if not runs else runs[min(max(self.run - 1, 0), len(runs) - 1)]
        buttons[[i for i in pressed if i < buttons.size]] = True
        return {"twist": np.asarray(self.config.twist, dtype=np.float64), "gripper": self.config.gripper,
                "buttons": buttons}


def synthetic_hand_keypoints(curl: float = 0.0, pinch: bool = False, side: str = "right") -> np.ndarray:
    """A plausible human hand's 25 keypoints (`HAND_JOINTS` order, meters) in RIO's palm frame (x from the
    wrist to the middle finger, z out of the palm, y = z x x: the thumb on -y for a right hand): fingers
    flexed by `curl` (0 open .. 1 fist), the thumb tip on the index tip when `pinch`. For tests of
    retargeting and hand-tracking teleop without a headset."""
    kp = np.zeros((25, 3))
    knuckles = ((0.090, -0.025), (0.095, -0.008), (0.088, 0.010), (0.080, 0.026))  # index, middle, ring, pinky
    bones, bends = (0.045, 0.027, 0.020), np.array([1.4, 1.6, 1.0]) * float(np.clip(curl, 0.0, 1.0))
    for k, (x, y) in enumerate(knuckles):
        i = 5 + 5 * k  # metacarpal, phalanx-proximal (knuckle), -intermediate, -distal, tip
        kp[i] = [0.02, 0.5 * y, 0.0]
        p, angle = np.array([x, y, 0.0]), 0.0
        kp[i + 1] = p
        for j, (length, bend) in enumerate(zip(bones, bends, strict=True)):
            angle += bend  # flexion turns the finger toward the palm side (+z)
            p = p + length * np.array([np.cos(angle), 0.0, np.sin(angle)])
            kp[i + 2 + j] = p
    kp[1:5] = [[0.020, -0.020, 0.010], [0.050, -0.045, 0.020], [0.075, -0.060, 0.025], [0.095, -0.070, 0.030]]
    if pinch:
        kp[4] = kp[9] + [0.0, -0.005, 0.0]
        kp[3] = 0.5 * (kp[2] + kp[4])
    if side == "left":
        kp[:, 1] *= -1.0
    return kp


class FakeHandTracker(ifc.TeleopNode):
    """A headset's hand tracking, scripted: both wrists start at `start` (the left one mirrored in y),
    then from `acquire_s` the hands are tracked, still for `still_s`, then move by `move` and turn by
    `turn_deg` about z over `seconds`, fingers curling to `curl`; optionally pinching, losing the hands,
    or pressing done."""

    hand_tracker = True

    class Config(ifc.TeleopNode.Config):
        rate_hz: float = Field(100.0, gt=0)
        hands: Literal["right", "left", "both"] = "right"
        start: list[float] = Field([0.3, -0.2, 1.0], min_length=3, max_length=3,
                                   description="right wrist at start (tracker frame, m)")
        move: list[float] = Field([0.0, 0.0, 0.0], min_length=3, max_length=3, description="wrist travel (m)")
        turn_deg: float = Field(0.0, description="wrist turn about z over the move (deg)")
        curl: float = Field(0.0, ge=0, le=1, description="finger curl reached at the end of the move")
        acquire_s: float = Field(0.2, ge=0, description="the hands are tracked from then on")
        still_s: float = Field(0.4, ge=0, description="tracked and still this long before the move starts (a "
                                                      "hand appears, then moves: the teleop anchors on it first)")
        seconds: float = Field(1.0, gt=0, description="duration of the move")
        pinch_after_s: float | None = Field(None, ge=0, description="pinch (gripper closes) from then on")
        lose_after_s: float | None = Field(None, ge=0, description="the hands are lost from then on")
        done_after_s: float | None = Field(None, ge=0, description="press done then (the run ends)")

    def open(self) -> None:
        self.t0 = clock.now()

    @remote
    def reset(self) -> float:
        self.t0 = clock.now()
        return 0.0

    def read_state(self) -> dict[str, Any]:
        from rio.control.rotations import quat_mul, quat_to_matrix, rotvec_to_quat

        c, t = self.config, clock.now() - self.t0
        u = float(np.clip((t - c.acquire_s - c.still_s) / c.seconds, 0.0, 1.0))
        out = ifc.teleop.hand_tracker_sample()
        on = c.acquire_s <= t and (c.lose_after_s is None or t < c.lose_after_s)
        turn = rotvec_to_quat([0.0, 0.0, np.deg2rad(c.turn_deg) * u])
        palm_down = np.array([0.0, 1.0, 0.0, 0.0])  # the palm frame's z (out of the palm) pointing down
        for side, i in (("left", ifc.teleop.LEFT), ("right", ifc.teleop.RIGHT)):
            mirror = np.array([1.0, -1.0 if side == "left" else 1.0, 1.0])
            p = np.asarray(c.start) * mirror + u * np.asarray(c.move)
            q = quat_mul(turn, palm_down)
            out["wrist_pose"][i] = np.r_[p, q]
            pinch = c.pinch_after_s is not None and t >= c.pinch_after_s
            local = synthetic_hand_keypoints(c.curl * u, pinch, side)
            out["hand_keypoints"][i] = p + local @ quat_to_matrix(q).T
            out["tracked"][i] = on and c.hands in (side, "both")
        driving = ifc.teleop.RIGHT if c.hands != "left" else ifc.teleop.LEFT
        buttons = np.zeros(c.buttons, bool)
        buttons[1:2] = c.done_after_s is not None and t >= c.done_after_s
        return {**out, "twist": np.zeros(6), "gripper": ifc.teleop.pinch_opening(out["hand_keypoints"][driving]),
                "buttons": buttons}
