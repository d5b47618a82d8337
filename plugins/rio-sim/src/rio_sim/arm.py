"""`sim.arm`: an arm of a sim world behind the standard `ArmNode` interface.

Joint targets go straight to the world (which interpolates them in physics time). End-effector
targets are turned into joint targets here, by the shared IK (`rio.kinematics.MinkSolver` on the
robot's own MJCF, so poses are in the arm's base frame), warm-started from the last joint target so
consecutive teleop targets give continuous joints. `robot_description()` hands the same model to a
control loop that prefers to do IK itself (a joint-space action space).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field
from rio.config import DriverConfig
from rio.errors import InvalidRequest
from rio.interfaces import ArmNode

from .attached import Attached
from .indices import arm_indices
from .robots import ROBOTS, get_robot


class SimArmConfig(DriverConfig):
    robot: str = Field("so100", description=f"robot model: {', '.join(sorted(ROBOTS))}")
    arm: str = Field("arm", description="which arm of the scene (its name prefix: arm, left, right)")
    world: str = Field("sim", description="the sim.world this arm lives in")
    rate_hz: float = Field(100.0, gt=0, description="state publishing rate (Hz)")
    ik_orientation_cost: float = Field(1.0, ge=0, description="orientation vs position weight of eef IK")


class SimArm(Attached, ArmNode):
    __api__ = (*ArmNode.__api__, "robot_description", "home")

    def __init__(self, robot: str = "so100", arm: str = "arm", world: str = "sim", rate_hz: float = 100.0,
                 ik_orientation_cost: float = 1.0):
        self.robot = get_robot(robot)
        super().__init__(self.robot.dof, rate_hz=rate_hz)
        self.arm, self.world, self.ik_orientation_cost = arm, world, float(ik_orientation_cost)
        self._ik = None
        self._q_cmd: np.ndarray | None = None

    def open(self) -> None:
        from rio.kinematics import MinkSolver

        self.attach_world()
        self.idx = arm_indices(self.model, self.arm, self.robot)
        self._ik = MinkSolver(str(self.robot.path), self.robot.tool_site, joints=list(self.robot.arm_joints),
                              orientation_cost=self.ik_orientation_cost, damping=1e-4)
        self._lower, self._upper = self._ik.lower, self._ik.upper

    def close(self) -> None:
        self.detach_world()

    def read_state(self) -> dict[str, Any]:
        s = self.world_state()
        q = s["qpos"][self.idx.qpos]
        return {"joint_pos": q, "joint_vel": s["qvel"][self.idx.dof], "eef_pose": self._ik.fk(q)}

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float) -> None:
        q = np.clip(joint_pos, self._lower, self._upper)
        self._q_cmd = q
        self.bus.command(self.idx.act, q, t_cmd_target)

    def command_eef(self, eef_pose: np.ndarray, t_cmd_target: float) -> None:
        seed = self._q_cmd if self._q_cmd is not None else self.world_state()["qpos"][self.idx.qpos]
        try:
            res = self._ik.solve(eef_pose, seed, max_iters=15)
        except ValueError as e:  # a zero quaternion
            raise InvalidRequest(self.name, "eef_pose", str(e)) from None
        self.command_joints(res.q, t_cmd_target)

    # -- remote API -----------------------------------------------------------------------------
    def robot_description(self) -> dict[str, Any]:
        """The arm's kinematic model for client-side IK (`rio.kinematics.solver_from_description`)."""
        return {"format": "mjcf", "xml": self.robot.xml(), "frame": self.robot.tool_site, "frame_type": "site",
                "joints": list(self.robot.arm_joints), "home": list(self.robot.home)}

    def home(self, seconds: float = 2.0) -> None:
        """Move to the home joints over `seconds`."""
        from rio import time as rtime

        self.command_joints(np.asarray(self.robot.home), rtime.now() + float(seconds))
