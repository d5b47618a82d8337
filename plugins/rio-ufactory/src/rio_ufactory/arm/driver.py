"""`ufactory.xarm5|xarm6|xarm7|xarm850|lite6`: a UFACTORY arm on its controller, through the xArm SDK.

Hardware logic only; the arm kind (`rio.interfaces.ArmNode`) owns the cycle and the safety. Each tick
reads the latest real-time report (no command round trip) and streams one servo target: joint goals
with `set_servo_angle_j`, end-effector goals with `set_servo_cartesian` (the controller's own Cartesian
servo; `eef_control = "ik"` solves IK on RIO's model instead). Servo mode (mode 1) executes only the
newest target, so the kind's commander (clip, step limit, watchdog) is what shapes the motion.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.interfaces import FAULT_KEYS, ArmNode, ModelTableArm

from ..controller import STOPPED as STOPPED_STATE
from ..description import description
from ..faults import STOPPED
from ..link import ControllerLink, LinkConfig
from ..models import ARMS, get_arm
from ..pose import from_xarm, to_xarm

Model = Literal["xarm5", "xarm6", "xarm7", "xarm850", "lite6"]


class XArm(ControllerLink, ModelTableArm, ArmNode):
    lookup_model = staticmethod(get_arm)
    describe_model = staticmethod(description)

    class Config(LinkConfig, ArmNode.Config):
        model: Model = Field("xarm7", description=f"which arm: {', '.join(ARMS)} (checked against the controller)")
        rate_hz: float = Field(250.0, gt=0, le=500, description="servo targets per second (the controller's "
                                                                "servo loop runs at 250 Hz)")
        max_step_rad: float = Field(0.01, gt=0, description="largest joint goal change per cycle (rad): 2.5 rad/s "
                                                            "at 250 Hz")
        max_step_m: float = Field(0.002, gt=0, description="largest tool travel per cycle (m): 0.5 m/s at 250 Hz")
        max_step_eef_rad: float = Field(0.01, gt=0, description="largest tool rotation per cycle (rad)")
        eef_control: Literal["controller", "ik"] = Field(
            "controller", description='end-effector targets through the controller\'s Cartesian servo '
                                      '("controller", its TCP offset applies) or RIO\'s IK on the arm model ("ik")')
        tcp_offset: tuple[float, float, float, float, float, float] | None = Field(
            None, description="tool centre point from the flange [x, y, z (m), roll, pitch, yaw (rad)], set on the "
                              "controller at start (its Cartesian servo and reported pose use it) and used by RIO's "
                              "model; default: the flange, and the controller's offset left as it is")
        collision_sensitivity: int | None = Field(None, ge=0, le=5, description="controller collision detection "
                                                                                 "0 (off) .. 5; default: as set")

    def setup(self) -> None:
        super().setup()
        self.arm = get_arm(self.config.model)
        self.model_name = self.arm.name
        self.example_data = {**self.example_data, **FAULT_KEYS, "report_age": 0.0}

    @property
    def streams_poses(self) -> bool:
        return self.config.eef_control == "controller"

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        ctl = self.open_controller()
        off = self.config.tcp_offset
        if off is not None:
            ctl.call("set_tcp_offset", [*(np.asarray(off[:3]) * 1000.0).tolist(), *off[3:]], is_radian=True)
        if self.config.collision_sensitivity is not None:
            ctl.call("set_collision_sensitivity", self.config.collision_sensitivity)

    def set_enabled(self, enabled: bool) -> None:
        assert self.ctl is not None
        if enabled:
            self.check_device_fault()
            self.ctl.enable_servo()
            self.ctl.wait_report(0.5)  # hold from a position measured after the controller is ready
        else:
            self.ctl.call("motion_enable", enable=False)  # brakes on: the arm stays where it is

    def read_joints(self) -> dict[str, Any]:
        assert self.ctl is not None
        ctl = self.ctl
        status = self.link_status()
        q, v = ctl.joints(self.dof)
        sample = {"joint_pos": q, "joint_vel": v, **status, "report_age": ctl.report_age}
        if self.streams_poses:  # the controller's TCP (its configured offset included) is the eef
            sample["eef_pose"] = from_xarm(ctl.tcp_pose())
        if self.enabled and ctl.connected and ctl.api.state == STOPPED_STATE and self.fault is None:
            fault = ctl.fault() or STOPPED  # stopped with no error: something else stopped it
            self.on_fault(fault)
            sample["fault_code"] = fault.code
        return sample

    def write_joints(self, joint_pos: np.ndarray) -> None:
        assert self.ctl is not None
        self.guarded(self.ctl.call, "set_servo_angle_j", joint_pos.tolist())

    def write_pose(self, eef_pose: np.ndarray) -> None:
        assert self.ctl is not None
        self.guarded(self.ctl.call, "set_servo_cartesian", to_xarm(eef_pose))

