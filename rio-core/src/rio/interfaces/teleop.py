"""The teleop contract: a device giving a spatial velocity, a gripper command and buttons.

A driver's `read_state()` returns `twist` (6: m/s, rad/s, in the robot's base frame), `gripper`
(0 closed .. 1 open) and `buttons` (n bools). A leader arm is a teleop device that also publishes
`joint_pos` / `joint_vel` and sets `leader_arm = True`: `rio teleop` then mirrors it joint by joint
(rio.teleop.leader_follower) instead of integrating its twist in end-effector space.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from ..node import Node, NodeConfig


class TeleopNode(Node):
    class Config(NodeConfig):
        buttons: int = Field(2, ge=0, le=64, description="number of buttons published")
    leader_arm: ClassVar[bool] = False

    def setup(self) -> None:
        self.example_data: dict[str, Any] = {"twist": np.zeros(6), "gripper": 1.0,
                                             "buttons": np.zeros(self.config.buttons, bool)}


TeleopConfig = TeleopNode.Config
