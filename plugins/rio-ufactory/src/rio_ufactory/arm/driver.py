"""`ufactory.xarm5|xarm6|xarm7|xarm850|lite6`: a UFACTORY arm on its control box, through the xArm SDK.

Hardware logic only; the arm kind (`rio.interfaces.ArmNode`) owns the cycle and the safety. Each tick
reads the latest real-time report (no command round trip) and streams one servo target: joint goals
with `set_servo_angle_j`, end-effector goals with `set_servo_cartesian` (the box's own Cartesian servo;
`eef_control = "ik"` solves IK on RIO's model instead). Servo mode (mode 1) executes only the newest
target, so the kind's commander (clip, step limit, watchdog) is what shapes the motion.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.interfaces import ArmNode, ModelTable, NetworkDevice

from ..connection import STOPPED as STOPPED_STATE
from ..connection import XArmConnection
from ..description import description
from ..faults import STOPPED
from ..link import guarded, hold_faults_and_drops
from ..models import ARMS, MAX_RATE_HZ, NODE_DEFAULTS
from ..pose import from_xarm, to_xarm

MODELS = ModelTable(ARMS, description, default="xarm7", defaults=NODE_DEFAULTS, max_rate_hz=MAX_RATE_HZ,
                    ik_extra="rio-ufactory[ik]")


class XArm(ArmNode):
    models = MODELS

    class Config(NetworkDevice, ArmNode.Config):
        defaults = MODELS.defaults
        renamed_values = {"eef_control": {"controller": "native"}}
        model: str = MODELS.field()
        eef_control: Literal["native", "ik"] = Field(
            "native", description='end-effector targets through the control box\'s Cartesian servo ("native", '
                                  'its TCP offset applies) or RIO\'s IK on the arm model ("ik")')
        tcp_offset: tuple[float, float, float, float, float, float] | None = Field(
            None, description="tool centre point from the flange [x, y, z (m), roll, pitch, yaw (rad)], set on the "
                              "control box at start (its Cartesian servo and reported pose use it) and used by RIO's "
                              "model; default: the flange, and the box's offset left as it is")
        collision_sensitivity: int | None = Field(None, ge=0, le=5, description="collision detection of the control "
                                                                                 "box, 0 (off) .. 5; default: as set")

    def setup(self) -> None:
        super().setup()
        self.conn: XArmConnection | None = None
        hold_faults_and_drops(self)
        self.example_data = {**self.example_data, "report_age": 0.0}

    @property
    def streams_poses(self) -> bool:
        return self.config.eef_control == "native"

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.conn = conn = XArmConnection.acquire(c.ip, model=c.model, connect_timeout_s=c.connect_timeout_s)
        if c.tcp_offset is not None:
            off = c.tcp_offset
            conn.call("set_tcp_offset", [*(np.asarray(off[:3]) * 1000.0).tolist(), *off[3:]], is_radian=True)
        if c.collision_sensitivity is not None:
            conn.call("set_collision_sensitivity", c.collision_sensitivity)

    def close(self) -> None:
        if self.conn is not None:
            self.conn.release()
            self.conn = None

    def set_enabled(self, enabled: bool) -> None:
        assert self.conn is not None
        if enabled:
            self.conn.enable_servo()
            self.conn.wait_report(0.5)  # hold from a position measured after the control box is ready
        else:
            self.conn.call("motion_enable", enable=False)  # brakes on: the arm stays where it is

    def read_joints(self) -> dict[str, Any]:
        conn = self.conn
        assert conn is not None
        self.link.watch()  # a dropped socket is noticed and retried here
        q, v = conn.joints(self.dof)
        sample = {"joint_pos": q, "joint_vel": v, "report_age": conn.report_age}
        if self.streams_poses:  # the control box's TCP (its configured offset included) is the eef
            sample["eef_pose"] = from_xarm(conn.tcp_pose())
        if self.enabled and conn.connected and conn.api.state == STOPPED_STATE and self.faults.fault is None:
            self.faults.report(conn.fault() or STOPPED)  # stopped with no error: something else stopped it
        return sample

    def write_joints(self, joint_pos: np.ndarray) -> None:
        assert self.conn is not None
        guarded(self, self.conn.call, "set_servo_angle_j", joint_pos.tolist())

    def write_pose(self, eef_pose: np.ndarray) -> None:
        assert self.conn is not None
        guarded(self, self.conn.call, "set_servo_cartesian", to_xarm(eef_pose))
