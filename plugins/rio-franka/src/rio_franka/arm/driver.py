"""`franka.fr3` / `franka.panda`: a Franka arm through franky (libfranka's 1 kHz control loop).

Hardware logic only; the arm kind (`rio.interfaces.ArmNode`) owns the cycle and the safety (clip, step
limit, watchdog). Each node cycle reads `robot.state` once and hands franky the cycle's goal as an
asynchronous motion that replaces the running one (`JointMotion` for joint goals, `CartesianMotion`
for end-effector goals, `eef_control = "native"`; "ik" solves IK on RIO's model instead). franky plans each
motion with Ruckig inside libfranka's 1 kHz loop, under `relative_dynamics_factor`, so the arm moves
smoothly between the node's (slower) goals. Reflexes and link drops become named, held faults
(`link.py`, `faults.py`).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces import ArmNode, Fault, FaultHolder, LinkSupervisor, ModelTable

from ..backend import connect_robot
from ..description import description
from ..faults import USER_STOPPED, fault_of, fault_of_state
from ..link import FrankaConfig, FrankaConnection, log
from ..models import ARMS, MAX_RATE_HZ, NODE_DEFAULTS, get_arm
from ..pose import ee_target, offset_pose, to_affine, tool_pose

MODELS = ModelTable(ARMS, description, default="fr3", defaults=NODE_DEFAULTS, max_rate_hz=MAX_RATE_HZ,
                    ik_extra="rio-franka[ik]")


class FrankaArm(ArmNode):
    models = MODELS

    class Config(FrankaConfig, ArmNode.Config):
        defaults = MODELS.defaults
        renamed_values = {"eef_control": {"franka": "native"}}
        model: str = MODELS.field()
        relative_dynamics_factor: float = Field(0.2, gt=0, le=1, description="scales Franka's velocity, "
                                                                             "acceleration and jerk limits")
        eef_control: Literal["native", "ik"] = Field(
            "native", description='end-effector targets as franky Cartesian motions ("native") or RIO\'s IK on '
                                  'the arm model then joint motions ("ik")')
        tcp_offset: tuple[float, float, float, float, float, float] | None = Field(
            None, description="tool centre point from the flange [x, y, z (m), roll, pitch, yaw (rad)]; the Franka "
                              "Hand's is [0, 0, 0.1034, 0, 0, -0.785398]; default: the flange")
        joint_impedance: tuple[float, ...] | None = Field(
            None, min_length=7, max_length=7, description="libfranka's joint stiffness (Nm/rad, 7 values); "
                                                          "default: as set")
        cartesian_impedance: tuple[float, ...] | None = Field(
            None, min_length=6, max_length=6, description="libfranka's Cartesian stiffness (N/m x3, Nm/rad x3); "
                                                          "default: as set")
        collision_torque_threshold: float | None = Field(None, gt=0, description="reflex torque threshold (Nm, all "
                                                                                 "joints); default: franky's 20")
        collision_force_threshold: float | None = Field(None, gt=0, description="reflex force threshold (N); "
                                                                                "default: franky's 30")
        auto_recover: bool = Field(False, description="after a reflex, run libfranka's error recovery by itself "
                                                      "(after auto_recover_delay_s) and hold where the arm is")
        auto_recover_delay_s: float = Field(1.0, ge=0, description="wait this long before an automatic recovery (s)")
        realtime: bool = Field(True, description="require a real-time kernel (libfranka's RealtimeConfig.Enforce)")

    def setup(self) -> None:
        super().setup()
        self.arm = get_arm(self.config.model)
        self.offset = offset_pose(self.config.tcp_offset)
        self.conn = FrankaConnection(self, self.connect, self.on_connected)
        self.faults = FaultHolder(self, f"Franka at {self.config.ip}", ask=self.device_fault,
                                  clear=lambda: self.conn.handle.recover_from_errors())  # libfranka's recovery
        self.link = LinkSupervisor(self.faults, up=lambda: self.conn.handle is not None, reconnect=self.conn.retry)
        self._q, self._dq = np.array(self.arm.home), np.zeros(7)
        self._f_t_ee: Any = None
        self._sent: tuple[str, np.ndarray] | None = None  # the goal the running motion holds
        self._fault_t = 0.0

    @property
    def streams_poses(self) -> bool:
        return self.config.eef_control == "native"

    # -- connection -----------------------------------------------------------------------------
    def connect(self) -> Any:
        c = self.config
        return connect_robot(c.ip, c.backend, c.model, c.relative_dynamics_factor, c.realtime)

    def on_connected(self, robot: Any) -> None:
        c = self.config
        if c.collision_torque_threshold is not None or c.collision_force_threshold is not None:
            robot.set_collision_behavior([c.collision_torque_threshold or 20.0] * 7,
                                         [c.collision_force_threshold or 30.0] * 6)
        if c.joint_impedance is not None:
            robot.set_joint_impedance(list(c.joint_impedance))
        if c.cartesian_impedance is not None:
            robot.set_cartesian_impedance(list(c.cartesian_impedance))

    def open(self) -> None:
        self.conn.open(self.config.connect_timeout_s)

    def close(self) -> None:
        self.conn.close()

    def device_fault(self) -> Fault | None:
        """The robot's fault now (its state's error flags and mode); the last one while the link is down."""
        if self.conn.handle is None:
            return self.faults.fault
        try:
            st = self.conn.handle.state
        except Exception:
            return None
        return fault_of_state(st)

    def set_enabled(self, enabled: bool) -> None:
        self._sent = None
        if self.conn.handle is not None and not enabled:
            self.conn.call(self.conn.handle.stop)  # the running motion ends; the arm holds where it is

    # -- the cycle ------------------------------------------------------------------------------
    def read_joints(self) -> dict[str, Any]:
        self.link.watch()  # retries a dropped link
        sample: dict[str, Any] = {"joint_pos": self._q, "joint_vel": self._dq}
        robot = self.conn.handle
        if robot is not None:
            try:
                st = robot.state
            except Exception as e:
                self.conn.classify(e)
                st = None
            if st is not None:
                self._q, self._dq = np.asarray(st.q, dtype=np.float64), np.asarray(st.dq, dtype=np.float64)
                self._f_t_ee = st.F_T_EE
                sample = {"joint_pos": self._q, "joint_vel": self._dq}
                if self.streams_poses:
                    sample["eef_pose"] = tool_pose(st.O_T_EE, st.F_T_EE, self.offset)
                fault = fault_of_state(st)
                if fault is not None and self.faults.fault is None and (self.enabled or fault is not USER_STOPPED):
                    self.faults.report(fault)
                    self._fault_t = clock.now()
                self._auto_recover()
        return sample

    def _auto_recover(self) -> None:
        held = self.faults.fault
        if (held is not None and self.config.auto_recover and held is not USER_STOPPED
                and clock.now() - self._fault_t >= self.config.auto_recover_delay_s):
            self._fault_t = clock.now()  # at most one try per delay
            try:
                self.clear_faults()
            except Exception as e:  # still faulted (e.g. the obstacle is still there): try again later
                self.faults.fault = self.faults.fault or fault_of(["joint_reflex"])
                self.enabled = False
                log.warning("node '%s': automatic recovery failed: %s", self.name, e)

    def write_joints(self, joint_pos: np.ndarray) -> None:
        if self.conn.handle is None or self._same("q", joint_pos):
            return  # holding: the running motion already holds this goal
        import franky

        motion = franky.JointMotion(franky.JointState(np.asarray(joint_pos, dtype=np.float64)),
                                    return_when_finished=False)
        self._sent = ("q", np.array(joint_pos, dtype=np.float64))
        self.conn.call(self.conn.handle.move, motion, True)

    def write_pose(self, eef_pose: np.ndarray) -> None:
        if self.conn.handle is None or self._f_t_ee is None:
            return
        if self._same("pose", eef_pose):
            return
        import franky

        target = to_affine(ee_target(np.asarray(eef_pose, dtype=np.float64), self._f_t_ee, self.offset))
        self._sent = ("pose", np.array(eef_pose, dtype=np.float64))
        self.conn.call(self.conn.handle.move,
                       franky.CartesianMotion(franky.RobotPose(target), return_when_finished=False), True)

    def _same(self, kind: str, goal: np.ndarray) -> bool:
        return self._sent is not None and self._sent[0] == kind and float(np.abs(goal - self._sent[1]).max()) < 1e-9
