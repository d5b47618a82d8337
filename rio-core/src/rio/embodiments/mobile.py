"""MobileManipulator: `base` + `arm` with optional `gripper` and `hand` -> `MobileManipulatorObs`.

Action (and `proprio`): the arm's part as in SingleArm (its target in the configured space, the gripper
opening, hand joints), then `base_twist` (3: vx, vy in m/s, wz in rad/s, the base's own frame). The base
part is a velocity held for the step: the base kind stops the base when steps stop coming
(`rio.interfaces.base`), so a policy that stalls never leaves it rolling.
"""

from __future__ import annotations

import numpy as np

from rio.embodiments.arm_group import ArmGroup
from rio.embodiments.base import Embodiment
from rio.embodiments.single_arm import ArmEmbodimentConfig
from rio.schema import MobileManipulatorObs

BASE_TWIST = "base_twist"


class MobileManipulator(Embodiment):
    name = "mobile_manipulator"
    required_roles = frozenset({"arm", "base"})
    optional_roles = frozenset({"gripper", "hand"})
    Config = ArmEmbodimentConfig

    def setup(self) -> None:
        self.group = ArmGroup(self, "arm", "gripper", "hand", self.config.action_space)

    def action_parts(self) -> list[tuple[str, int]]:
        return [*self.group.layout(), (BASE_TWIST, 3)]

    def observe(self) -> MobileManipulatorObs:
        g = self.group.read()
        b = self._state("base")
        twist = np.asarray(b["body_twist"], dtype=np.float64)
        return MobileManipulatorObs(proprio=np.concatenate([g["proprio"], twist]), proprio_eef=g["eef"],
                                    proprio_joints=g["joints"], gripper_width=g["gripper_width"],
                                    hand_joints=g["hand_joints"], base_twist=twist,
                                    base_odom=np.asarray(b["odom_pose"], dtype=np.float64),
                                    base_wheel_pos=np.asarray(b["wheel_pos"], dtype=np.float64),
                                    base_wheel_vel=np.asarray(b["wheel_vel"], dtype=np.float64))

    def apply(self, parts: dict[str, np.ndarray], t_cmd_target: float) -> None:
        self.group.apply(parts, t_cmd_target)
        self.send("base", "move_twist", parts[BASE_TWIST], t_cmd_target)

    def reset(self) -> None:
        """Stop the base (the arm holds where it is)."""
        self.clients["base"].stop()
