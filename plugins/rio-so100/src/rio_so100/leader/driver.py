"""The leader arm: a teleop device publishing the joint angles a person puts it in.

It keeps its servos' torque off (it is moved by hand) and publishes, each tick, `joint_pos` /
`joint_vel` in the follower's convention (same calibration procedure, same middle pose, so the same
pose reads the same radians) and the jaw opening as `gripper` (0 closed .. 1 open). It also carries
the keys every `TeleopNode` has (`twist` zero, `buttons`), so tools that only know twist devices
can still open it. Leader-follower teleop is `rio.teleop.leader_follower`.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.interfaces import TeleopNode
from rio.runtime.node import client_side, remote

from ..models import ARM_JOINTS, GRIPPER
from ..servo_node import ServoConfig, Servos

_ZERO_TWIST = np.zeros(6)


class So100Leader(TeleopNode):
    client_state = ("joint_list",)

    class Config(ServoConfig, TeleopNode.Config):
        defaults = {"rate_hz": Field(100.0, le=500)}
        renamed = {"virtual_motion": "emulator_motion"}
        joints: list[str] = Field(default_factory=lambda: list(ARM_JOINTS), description="arm joints, in order")
        gripper: str | None = Field(GRIPPER, description="the jaw joint (its opening is published as `gripper`), "
                                                         "or none")
        emulator_motion: Literal["none", "wave"] = Field("none", description='with port = "emulator": a scripted '
                                                                           'hand moving the arm ("wave")')

    leader_arm = True  # `rio teleop` mirrors it joint by joint

    def setup(self) -> None:
        super().setup()
        self.servos = Servos(self.config, "leader")
        self.joint_list, self.gripper_joint = list(self.config.joints), self.config.gripper
        n = len(self.joint_list)
        self.example_data = {**self.example_data, "joint_pos": np.zeros(n), "joint_vel": np.zeros(n),
                             "error": np.zeros(n + (self.gripper_joint is not None), np.int64)}
        self._no_buttons = np.zeros(self.config.buttons, bool)

    def open(self) -> None:
        names = self.joint_list + ([self.gripper_joint] if self.gripper_joint else [])
        self.servos.open(names, emulator_motion=self.config.emulator_motion).set_torque(False)

    def close(self) -> None:
        self.servos.close()

    def read_state(self) -> dict[str, Any]:
        s = self.servos.read(hold=False)  # moved by hand: never frozen
        n = len(self.joint_list)
        grip = self.servos.group.cal[n].fraction(s["steps"][n]) if self.gripper_joint else 1.0
        return {"twist": _ZERO_TWIST, "gripper": grip, "buttons": self._no_buttons, "joint_pos": s["joint_pos"][:n],
                "joint_vel": s["joint_vel"][:n], "error": s["error"]}

    @client_side
    def joint_names(self) -> list[str]:
        return list(self.joint_list)

    @client_side
    def num_joints(self) -> int:
        return len(self.joint_list)

    @remote
    def torque(self, enabled: bool = False) -> bool:
        """A leader with torque on holds its pose (e.g. to park it); off again to teleoperate."""
        self.servos.group.set_torque(bool(enabled))
        return bool(enabled)
