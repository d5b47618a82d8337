"""The leader arm: a teleop device publishing the joint angles a person puts it in.

It keeps its servos' torque off (it is moved by hand) and publishes, each tick, `joint_pos` /
`joint_vel` in the follower's convention (same calibration procedure, same middle pose, so the same
pose reads the same radians) and the jaw opening as `gripper` (0 closed .. 1 open). It also carries
the keys every `TeleopNode` has (`twist` zero, `buttons`), so tools that only know twist devices
can still open it. Leader-follower teleop is `rio_so100.leader_follower`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from rio.interfaces import TeleopNode
from rio.node import client_side

from ..connection import ArmConnection
from ..models import ARM_JOINTS, GRIPPER

_ZERO_TWIST = np.zeros(6)
_NO_BUTTONS = np.zeros(2, bool)


class So100Leader(TeleopNode):
    __api__ = ("get_state", "joint_names", "num_joints", "torque")
    role = "leader"
    leader_arm = True  # `rio teleop` mirrors it joint by joint

    def __init__(self, port: str, calibration: str = "default", model: str = "so100",
                 joints: list[str] | None = None, gripper: str | None = GRIPPER, rate_hz: float = 100.0,
                 baudrate: int = 1_000_000, retries: int = 2, virtual_motion: str = "none"):
        super().__init__(buttons=2, rate_hz=rate_hz)
        self.joint_list, self.gripper_joint = list(joints or ARM_JOINTS), gripper
        n = len(self.joint_list)
        self.example_data = {**self.example_data, "joint_pos": np.zeros(n), "joint_vel": np.zeros(n),
                             "error": np.zeros(n + (gripper is not None), np.int64)}
        self.conn = ArmConnection(port, model=model, role=self.role, calibration=calibration, baudrate=baudrate,
                                  retries=retries, virtual_motion=virtual_motion)
        self.group = None

    def open(self) -> None:
        names = self.joint_list + ([self.gripper_joint] if self.gripper_joint else [])
        self.group = self.conn.open(names)
        self.group.set_torque(False)

    def close(self) -> None:
        self.conn.close()

    def read_state(self) -> dict[str, Any]:
        s = self.group.read()
        self.group.check_faults(s, hold=False)
        n = len(self.joint_list)
        grip = self.group.cal[n].fraction(s["steps"][n]) if self.gripper_joint else 1.0
        return {"twist": _ZERO_TWIST, "gripper": grip, "buttons": _NO_BUTTONS, "joint_pos": s["joint_pos"][:n],
                "joint_vel": s["joint_vel"][:n], "error": s["error"]}

    @client_side
    def joint_names(self) -> list[str]:
        return list(self.joint_list)

    @client_side
    def num_joints(self) -> int:
        return len(self.joint_list)

    def torque(self, enabled: bool = False) -> bool:
        """A leader with torque on holds its pose (e.g. to park it); off again to teleoperate."""
        self.group.set_torque(bool(enabled))
        return bool(enabled)


class So101Leader(So100Leader):
    def __init__(self, port: str, calibration: str = "default", model: str = "so101", **kwargs: Any):
        super().__init__(port, calibration, model, **kwargs)
