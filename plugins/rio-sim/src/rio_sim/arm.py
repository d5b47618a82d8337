"""`sim.arm`: an arm of a sim world behind the standard `ArmNode` contract.

The world is this driver's hardware: each cycle the arm reads its joints from the world bus and writes
the commander's goal for the next tick (the world interpolates it in physics time). Joint limits come
from the robot's MJCF; `robot_description()` hands out the same model, so the arm kind computes the
end-effector pose and solves end-effector targets with the shared IK, as it would for any real arm
that ships a model.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces import ArmNode

from .attached import WorldAttachment
from .indices import arm_indices
from .robots import ROBOTS, RobotModel, get_robot
from .wrist_ft import wrist_ft_indices


class SimArm(ArmNode):
    class Config(ArmNode.Config):
        defaults = {"max_step_rad": 0.1}
        robot: str = Field("so100", description=f"robot model: {', '.join(sorted(ROBOTS))}")
        arm: str = Field("arm", description="which arm of the scene (its name prefix: arm, left, right)")
        world: str = Field("sim", description="the sim.world this arm lives in")

    def setup(self) -> None:
        self.robot = get_robot(self.config.robot)
        self.arm = self.config.arm
        super().setup()
        self.sim = WorldAttachment(self.config.world)

    def default_joint_names(self) -> list[str]:
        return list(self.robot.arm_joints)

    def default_home(self) -> list[float]:
        return list(self.robot.home)

    def open(self) -> None:
        self.sim.attach()
        self.idx = arm_indices(self.sim.model, self.arm, self.robot)
        self.ft = wrist_ft_indices(self.sim.model, self.arm)

    def close(self) -> None:
        self.sim.detach()

    def hardware_limits(self) -> tuple[np.ndarray, np.ndarray]:
        ranges = np.array([self.sim.model.joint(f"{self.arm}/{n}").range for n in self.robot.arm_joints])
        return ranges[:, 0], ranges[:, 1]

    def read_joints(self) -> dict[str, Any]:
        s = self.sim.state()
        return {"joint_pos": s["qpos"][self.idx.qpos], "joint_vel": s["qvel"][self.idx.dof]}

    def read_wrench(self) -> np.ndarray:
        """The wrist force/torque sensor's reading (`rio_sim.wrist_ft`): the arm's wrench source for a
        station's `force_limit`, as a real arm's wrist cell or external-force estimate would be."""
        return self.sim.state()["sensordata"][self.ft].copy()

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.sim.bus.command(self.idx.act, joint_pos, clock.now() + 1.0 / self.rate_hz)

    def robot_description(self) -> dict[str, Any]:
        """The robot's MJCF, its tool site and arm joints (shared IK and forward kinematics)."""
        return robot_description(self.robot)


def robot_description(robot: RobotModel) -> dict[str, Any]:
    """What `sim.arm` hands out as its `robot_description()`, for the arm kind's kinematics."""
    return {"format": "mjcf", "xml": robot.xml(), "frame": robot.tool_site, "frame_type": "site",
            "joints": list(robot.arm_joints), "home": list(robot.home)}
