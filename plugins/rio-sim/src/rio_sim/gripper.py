"""`sim.gripper`: the parallel gripper of a sim arm behind the standard `GripperNode` interface.
The opening (m) is the sum of the finger slides; a target is split evenly between the fingers.
Grasping is physics: fingers stop on an object and squeeze it with their actuators' force."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field
from rio.config import DriverConfig
from rio.interfaces import GripperNode

from .attached import Attached
from .indices import arm_indices
from .robots import ROBOTS, get_robot


class SimGripperConfig(DriverConfig):
    robot: str = Field("so100", description=f"robot model the gripper belongs to: {', '.join(sorted(ROBOTS))}")
    arm: str = Field("arm", description="which arm of the scene the gripper is on")
    world: str = Field("sim", description="the sim.world it lives in")
    rate_hz: float = Field(50.0, gt=0)


class SimGripper(Attached, GripperNode):
    def __init__(self, robot: str = "so100", arm: str = "arm", world: str = "sim", rate_hz: float = 50.0):
        self.robot = get_robot(robot)
        super().__init__(self.robot.max_width, rate_hz=rate_hz)
        self.arm, self.world = arm, world

    def open(self) -> None:
        self.attach_world()
        self.idx = arm_indices(self.model, self.arm, self.robot)

    def close(self) -> None:
        self.detach_world()

    def read_state(self) -> dict[str, Any]:
        s = self.world_state()
        return {"position": float(np.sum(s["qpos"][self.idx.finger_qpos])), "max_width": self.width}

    def command_position(self, position: float, t_cmd_target: float) -> None:
        n = len(self.idx.finger_act)
        self.bus.command(self.idx.finger_act, np.full(n, position / n), t_cmd_target)
