"""`sim.gripper`: the parallel gripper of a sim arm behind the standard `GripperNode` contract.
The opening (m) is the sum of the finger slides; a goal is split evenly between the fingers.
Grasping is physics: fingers stop on an object and squeeze it with their actuators' force."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces import GripperNode

from .attached import WorldAttachment
from .indices import arm_indices
from .robots import ROBOTS, get_robot


class SimGripper(GripperNode):
    class Config(GripperNode.Config):
        robot: str = Field("so100", description=f"robot model the gripper belongs to: {', '.join(sorted(ROBOTS))}")
        arm: str = Field("arm", description="which arm of the scene the gripper is on")
        world: str = Field("sim", description="the sim.world it lives in")
        max_width: float | None = Field(None, gt=0, description="full opening (m); default: the robot model's")

    def setup(self) -> None:
        self.robot = get_robot(self.config.robot)
        if self.config.max_width is None:
            self.config = self.config.model_copy(update={"max_width": self.robot.max_width})
        self.arm = self.config.arm
        super().setup()
        self.sim = WorldAttachment(self.config.world)

    def open(self) -> None:
        self.sim.attach()
        self.idx = arm_indices(self.sim.model, self.arm, self.robot)

    def close(self) -> None:
        self.sim.detach()

    def read_width(self) -> dict[str, Any]:
        return {"width": float(np.sum(self.sim.state()["qpos"][self.idx.finger_qpos]))}

    def write_width(self, width: float, force: float) -> None:
        n = len(self.idx.finger_act)
        self.sim.bus.command(self.idx.finger_act, np.full(n, width / n), clock.now() + 1.0 / self.rate_hz)
