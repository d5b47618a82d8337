"""Bimanual: `arm` (left, "arm1" in the schema) + `arm2` (right), each with optional gripper and hand.

Action (and `proprio`): the left group then the right group, each laid out as in SingleArm; labels
are prefixed `arm1_` / `arm2_`.
"""

from __future__ import annotations

import numpy as np

from rio.embodiments.arm_group import ArmGroup
from rio.embodiments.base import Embodiment
from rio.embodiments.single_arm import ArmEmbodimentConfig
from rio.schema import BimanualObs


class Bimanual(Embodiment):
    name = "bimanual"
    required_roles = frozenset({"arm", "arm2"})
    optional_roles = frozenset({"gripper", "gripper2", "hand", "hand2"})
    Config = ArmEmbodimentConfig

    def setup(self) -> None:
        space = self.config.action_space
        self.left = ArmGroup(self, "arm", "gripper", "hand", space, prefix="arm1_")
        self.right = ArmGroup(self, "arm2", "gripper2", "hand2", space, prefix="arm2_")

    def action_parts(self) -> list[tuple[str, int]]:
        return self.left.layout() + self.right.layout()

    def action_names(self) -> list[str]:
        return self.named_or_numbered(self.left.names()["action"] + self.right.names()["action"])

    def observation_names(self) -> dict[str, list[str]]:
        out = {"proprio": self.action_names()}
        for k, g in (("1", self.left.names()), ("2", self.right.names())):
            out[f"arm{k}_proprio_joints"], out[f"arm{k}_proprio_eef"] = g["joints"], g["eef"]
            if "hand" in g:
                out[f"hand{k}_joints"] = g["hand"]
        return out

    def observe(self) -> BimanualObs:
        a, b = self.left.read(), self.right.read()
        return BimanualObs(
            proprio=np.concatenate([a["proprio"], b["proprio"]]),
            arm1_proprio_eef=a["eef"], arm1_proprio_joints=a["joints"], gripper1_width=a["gripper_width"],
            hand1_joints=a["hand_joints"],
            arm2_proprio_eef=b["eef"], arm2_proprio_joints=b["joints"], gripper2_width=b["gripper_width"],
            hand2_joints=b["hand_joints"],
        )

    def apply(self, parts: dict[str, np.ndarray], t_cmd_target: float) -> None:
        self.left.apply(parts, t_cmd_target)
        self.right.apply(parts, t_cmd_target)
