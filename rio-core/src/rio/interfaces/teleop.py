"""The teleop contract: a device giving a spatial velocity, a gripper command and buttons.

A driver's `read_state()` returns `twist` (6: m/s, rad/s, in the robot's base frame), `gripper`
(0 closed .. 1 open) and `buttons` (n bools). A device that knows its own motion exactly (a script)
also publishes `displacement` (6: the integral of its twist since it started, m and rad): the loop
then moves by its differences rather than integrating the twist samples, so a stretch without samples
(its thread descheduled, the loop late) costs nothing; without it, the loop integrates the twist
over the samples' timestamps (rio.teleop.twist.DevicePoll). A leader arm is a teleop device that also publishes
`joint_pos` / `joint_vel` and sets `leader_arm = True`: `rio teleop` then mirrors it joint by joint
(rio.teleop.leader_follower) instead of integrating its twist in end-effector space.

A hand tracker (a VR headset's hand or controller tracking) sets `hand_tracker = True` and also
publishes, for both hands (index 0 left, 1 right):

    wrist_pose      (2, 7)      each wrist's pose [x, y, z, qw, qx, qy, qz]
    hand_keypoints  (2, 25, 3)  the hand's joints in `HAND_JOINTS` order (the WebXR / visionOS
                                skeleton), positions in the same frame as `wrist_pose`
    tracked         (2,) bool   whether that hand is tracked now (its values are stale when not)

in the tracker's own world frame turned to the robot's axes (x forward, y left, z up; meters), with
`twist` zero and `gripper` from the driving hand's pinch. `rio teleop` then retargets them
(rio.teleop.hands): wrist motion since the hand was (re)acquired moves each arm's tool, or a
humanoid's wrists; keypoints drive dexterous hands (rio.kinematics.hand_retarget).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from rio.kinematics.hand_skeleton import HAND_JOINTS as HAND_JOINTS  # re-exported: part of the teleop contract
from rio.runtime.node import Node, NodeConfig

LEFT, RIGHT = 0, 1


def hand_tracker_sample() -> dict[str, Any]:
    """The extra keys of a hand tracker's sample, nothing tracked (see the module docstring)."""
    pose = np.zeros((2, 7))
    pose[:, 3] = 1.0
    return {"wrist_pose": pose, "hand_keypoints": np.zeros((2, len(HAND_JOINTS), 3)), "tracked": np.zeros(2, bool)}


def pinch_opening(keypoints: np.ndarray, closed_m: float = 0.015, open_m: float = 0.08) -> float:
    """A tracked hand's gripper command, 0 closed .. 1 open, from its thumb-tip to index-tip distance
    (linear between `closed_m` and `open_m`): one rule for every hand tracker."""
    kp = np.asarray(keypoints, dtype=np.float64)
    d = float(np.linalg.norm(kp[HAND_JOINTS.index("thumb-tip")] - kp[HAND_JOINTS.index("index-finger-tip")]))
    return float(np.clip((d - closed_m) / (open_m - closed_m), 0.0, 1.0))


class TeleopNode(Node):
    class Config(NodeConfig):
        buttons: int = Field(2, ge=0, le=64, description="number of buttons published")
    leader_arm: ClassVar[bool] = False
    hand_tracker: ClassVar[bool] = False

    def setup(self) -> None:
        self.example_data: dict[str, Any] = {"twist": np.zeros(6), "gripper": 1.0,
                                             "buttons": np.zeros(self.config.buttons, bool)}
        if self.hand_tracker:
            self.example_data.update(hand_tracker_sample())


TeleopConfig = TeleopNode.Config
