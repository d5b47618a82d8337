"""SingleArm: `arm` with optional `gripper` and `hand` -> `SingleArmObs`.

Action (and `proprio`): the arm target in the configured space (`joint_pos`: n joints in rad, or
`eef_pose`: 7 values, m + quaternion wxyz), then the gripper opening (m), then hand joints (rad).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from rio.embodiments.arm_group import ArmGroup
from rio.embodiments.base import Embodiment, EmbodimentConfig
from rio.schema import SingleArmObs


class SingleArm(Embodiment):
    name = "single_arm"
    required_roles = frozenset({"arm"})
    optional_roles = frozenset({"gripper", "hand"})
    class Config(EmbodimentConfig):
        action_space: Literal["joint_pos", "eef_pose"] = Field(default="joint_pos",
                                                               description="what an action commands for each arm")

    def setup(self) -> None:
        self.group = ArmGroup(self, "arm", "gripper", "hand", self.config.action_space)

    def action_parts(self) -> list[tuple[str, int]]:
        return self.group.layout()

    def action_names(self) -> list[str]:
        return self.named_or_numbered(self.group.names()["action"])

    def observation_names(self) -> dict[str, list[str]]:
        g = self.group.names()
        out = {"proprio": self.action_names(), "proprio_joints": g["joints"], "proprio_eef": g["eef"]}
        if "hand" in g:
            out["hand_joints"] = g["hand"]
        return out

    def observe(self) -> SingleArmObs:
        g = self.group.read()
        return SingleArmObs(proprio=g["proprio"], proprio_eef=g["eef"], proprio_joints=g["joints"],
                            gripper_width=g["gripper_width"], hand_joints=g["hand_joints"])

    def apply(self, parts: dict[str, np.ndarray], t_cmd_target: float) -> None:
        self.group.apply(parts, t_cmd_target)


ArmEmbodimentConfig = SingleArm.Config
