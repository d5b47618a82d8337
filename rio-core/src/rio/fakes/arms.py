"""Fake arms and a fake gripper: the `rio.fake_arm`, `rio.fake_model_arm` and `rio.fake_gripper` drivers."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio import interfaces as ifc
from rio.errors import RioError


class FakeArm(ifc.ArmNode):
    """Arm with joint and Cartesian control and no kinematic model. Its tool is carried by its joints
    the way a gantry's is (each joint moves it 0.1 m per rad along one axis: joint i along x, y, z for
    i mod 3 = 0, 1, 2), so the measured pose follows joint moves; an end-effector goal moves the tool
    directly and leaves the joints where they are."""

    class Config(ifc.ArmNode.Config):
        defaults = {"max_step_rad": 0.5, "max_tool_step_m": 0.05, "max_tool_step_rad": 0.5,
                    "workspace": Field(((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)), description=(
                        "[[x, y, z] lower, [x, y, z] upper] (m): the box the tool stays in (a fake has no model "
                        "to take its reach from: 1 m around where its tool starts at zero joints)"))}
        dof: int = Field(6, ge=1, le=64, description="number of joints (named joint1..N)")
        frozen: bool = Field(False, description="ignore every command, as a disabled or e-stopped arm does (to "
                                                "check that a workflow notices)")
        start: list[float] | None = Field(None, description="joint positions it starts at (rad; default: home), "
                                                            "an arm left away from home (homing tests)")
        fail: Literal["error", "fault", "stop"] | None = Field(
            None, description="go wrong `fail_after_s` after the first command, to check that a workflow says so: "
                              "'error' "
                              "(the node stops with a RioError, as a lost device does), 'fault' (the arm reports a "
                              "fault and holds, disabled), 'stop' (an emergency stop disables it, no fault)")
        fail_after_s: float = Field(0.5, ge=0, description="when `fail` happens (s after the first command)")

    def default_joint_names(self) -> list[str]:
        return numbered_joints(self.config.dof)

    def setup(self) -> None:
        super().setup()
        if self.config.fail == "fault":
            self.faults = ifc.FaultHolder(self, "the fake arm")

    def open(self) -> None:
        self._t_fail: float | None = None  # set by the first command (`fail`)
        home = self.config.start if self.config.start is not None else self.config.home
        self.q = np.zeros(self.dof) if home is None else np.asarray(home, dtype=np.float64)
        #: tool travel (m) per joint motion (rad): 3 x dof
        self._carry = 0.1 * (np.arange(3)[:, None] == np.arange(self.dof)[None, :] % 3)
        self.pose = ifc.IDENTITY_POSE.copy()
        self.pose[:3] = self._carry @ self.q
        self._q_prev, self._t_prev = self.q.copy(), clock.now()

    def read_joints(self) -> dict[str, Any]:
        t = clock.now()
        if self._t_fail is not None and t >= self._t_fail:
            self._go_wrong()
        vel = (self.q - self._q_prev) / max(t - self._t_prev, 1e-6)
        self._q_prev, self._t_prev = self.q.copy(), t
        return {"joint_pos": self.q.copy(), "joint_vel": vel, "eef_pose": self.pose.copy()}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        if self.config.frozen:
            return
        q = np.array(joint_pos, dtype=np.float64)
        self.pose[:3] += self._carry @ (q - self.q)  # the joints carry the tool
        self.q = q

    def write_pose(self, eef_pose: np.ndarray) -> None:
        if not self.config.frozen:
            self.pose = np.array(eef_pose, dtype=np.float64)

    def handle_request(self, request: dict[str, Any]) -> None:
        if self.config.fail and self._t_fail is None:
            self._t_fail = clock.now() + self.config.fail_after_s  # a workflow drives the arm: the clock starts
        super().handle_request(request)

    def _go_wrong(self) -> None:
        """`fail`, once, `fail_after_s` after the first command."""
        self._t_fail = float("inf")  # once (not None: the next command would arm it anew)
        if self.config.fail == "error":
            raise RioError("the fake arm stopped answering (fail = 'error')")
        if self.config.fail == "fault":
            assert self.faults is not None  # made in setup() for fail = 'fault'
            self.faults.report(ifc.Fault(9, "fake_fault", "the fake arm reported a fault (fail = 'fault')",
                                         "clear_faults()"))
        else:  # "stop": what a pressed emergency stop does to a driver without a fault table
            self.enabled = False


def numbered_joints(n: int) -> list[str]:
    return [f"joint{i + 1}" for i in range(n)]


def at_home(node: Any) -> np.ndarray:
    """Where a fake's joints start: at the configured home when there is one (a pose away from
    singularities), else zeros. The fakes' joints then follow their goal (`write_joints` stores it)."""
    home = node.config.home
    return np.zeros(node.dof) if home is None else np.asarray(home, dtype=np.float64)


#: A 6-joint arm for tests of the kinematic part of the arm contract (simple geoms, tool site "tool"):
#: yaw, two pitches, then a spherical wrist (roll, pitch, roll). Arm straight up at zero.
SIX_DOF_MJCF = """<mujoco model="rio-test-arm">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="base">
      <geom type="cylinder" size="0.04 0.02"/>
      <body name="l1" pos="0 0 0.05"><joint name="j1" axis="0 0 1" range="-3 3"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.1" size="0.02"/>
        <body name="l2" pos="0 0 0.1"><joint name="j2" axis="0 1 0" range="-2 2"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.2" size="0.02"/>
          <body name="l3" pos="0 0 0.2"><joint name="j3" axis="0 1 0" range="-2.5 2.5"/>
            <geom type="capsule" fromto="0 0 0 0 0 0.2" size="0.02"/>
            <body name="l4" pos="0 0 0.2"><joint name="j4" axis="0 0 1" range="-3 3"/>
              <geom type="sphere" size="0.02"/>
              <body name="l5" pos="0 0 0.04"><joint name="j5" axis="0 1 0" range="-2 2"/>
                <geom type="sphere" size="0.02"/>
                <body name="l6" pos="0 0 0.04"><joint name="j6" axis="0 0 1" range="-3 3"/>
                  <geom type="box" size="0.02 0.02 0.01"/>
                  <site name="tool" pos="0 0 0.05"/>
                </body></body></body></body></body></body>
    </body>
  </worldbody>
</mujoco>"""


class FakeModelArm(ifc.ArmNode):
    """A joint-only arm that ships a robot model and measures no end-effector pose: the arm kind
    computes `eef_pose` by forward kinematics and turns end-effector targets into joint targets by IK
    (needs `rio-core[ik]`)."""

    class Config(ifc.ArmNode.Config):
        defaults = {"max_step_rad": 0.5}

    def default_joint_names(self) -> list[str]:
        return [f"j{i + 1}" for i in range(6)]

    def default_home(self) -> list[float]:
        return [0.0, 0.5, 1.2, 0.0, 1.4, 0.0]  # tool in front of the base, pointing down

    def open(self) -> None:
        self.q = at_home(self)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy()}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.q = np.array(joint_pos, dtype=np.float64)

    def robot_description(self) -> dict[str, Any]:
        return {"format": "mjcf", "xml": SIX_DOF_MJCF, "frame": "tool", "frame_type": "site",
                "joints": list(self.joint_list), "home": self.default_home()}


class FakeGripper(ifc.GripperNode):
    """Parallel gripper whose fingers follow the goal; starts fully open."""

    class Config(ifc.GripperNode.Config):
        defaults = {"rate_hz": 100.0, "max_step_m": 0.05}

    def open(self) -> None:
        self.opening = self.width

    def read_width(self) -> dict[str, Any]:
        return {"width": float(self.opening)}

    def write_width(self, width: float, force: float) -> None:
        self.opening = float(width)
