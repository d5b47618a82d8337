"""`ur.ur3e|ur5e|ur7e|ur10e|ur12e|ur16e|ur20|ur30`: a Universal Robots arm through ur-rtde.

Hardware logic only; the arm kind (`rio.interfaces.ArmNode`) owns the cycle, the interpolation and the
safety. Each tick copies the latest RTDE state and streams one servo target: joint goals with `servoJ`,
end-effector goals with `servoL` (the controller's own Cartesian servo, `eef_control = "native"`; "ik"
solves IK on RIO's model instead). servoJ executes only the newest target, smoothed over
`lookahead_time`, so the kind's commander (clip, step limit, watchdog) is what shapes the motion.

A protective or emergency stop, a power-off or brakes on do not end the node: it reports `fault_code`,
refuses commands naming the fault and holds; `clear_faults()` (dashboard: close the popup, unlock, power
on, release the brakes) brings it back holding where the arm is. Faults and connection drops are held by
the core's parts (`rio.interfaces.FaultHolder`, `LinkSupervisor`); this says how to ask and clear the UR.
"""

from __future__ import annotations

import logging
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.control import quat_to_rotvec, rotvec_to_quat
from rio.interfaces import ArmNode, Fault, FaultHolder, LinkSupervisor, ModelTable, NetworkDevice

from ..connection import URConnection
from ..description import description
from ..faults import fault_of
from ..models import ARMS, MAX_RATE_HZ, NODE_DEFAULTS

log = logging.getLogger("rio_ur")
MODELS = ModelTable(ARMS, description, default="ur5e", defaults=NODE_DEFAULTS, max_rate_hz=MAX_RATE_HZ,
                    ik_extra="rio-ur[ik]")


def from_ur(pose: Any) -> np.ndarray:
    """UR's [x, y, z, rx, ry, rz] (rotation vector) -> RIO's [x, y, z, qw, qx, qy, qz]."""
    p = np.asarray(pose, dtype=np.float64)
    return np.concatenate([p[:3], rotvec_to_quat(p[3:])])


def to_ur(pose: np.ndarray) -> list[float]:
    return [*map(float, pose[:3]), *map(float, quat_to_rotvec(pose[3:]))]


class URArm(ArmNode):
    models = MODELS

    class Config(NetworkDevice, ArmNode.Config):
        defaults = MODELS.defaults
        renamed_values = {"eef_control": {"controller": "native"}}
        model: str = MODELS.field()
        control: Literal["rtde", "emulator"] = Field(
            "rtde", description='"rtde": ur-rtde\'s control interface (the real arm); "emulator": the emulator\'s '
                                "servo port (`rio ur emulator`, the emulator stations)")
        lookahead_time: float = Field(0.1, ge=0.03, le=0.2, description="servoJ/servoL smoothing (s)")
        gain: float = Field(300.0, ge=100, le=2000, description="servoJ/servoL proportional gain")
        eef_control: Literal["native", "ik"] = Field(
            "native", description='end-effector targets through servoL ("native") or RIO\'s IK ("ik")')
        tcp_offset: tuple[float, float, float, float, float, float] | None = Field(
            None, description="tool centre point from the flange [x, y, z (m), rx, ry, rz (rotation vector)], set "
                              "on the controller at start; default: as set on the pendant for servoL, the flange "
                              "for RIO's model")

    def setup(self) -> None:
        super().setup()
        self.conn: URConnection | None = None
        self.faults = FaultHolder(self, f"UR at {self.config.ip}", ask=self.device_fault,
                                  clear=self.clear_device_faults)
        self.link = LinkSupervisor(self.faults, up=lambda: self.conn is not None and self.conn.connected,
                                   reconnect=lambda: self.conn.reconnect())
        self._scaling_warned = False
        self.example_data = {**self.example_data, "speed_scaling": 1.0, "safety_mode": 1, "robot_mode": 7}

    @property
    def streams_poses(self) -> bool:
        return self.config.eef_control == "native"

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.conn = URConnection(c.ip, c.control, c.rate_hz, c.connect_timeout_s)
        self.conn.open()
        if c.tcp_offset is not None:
            self.conn.ctl.setTcp(list(c.tcp_offset))

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
            self.conn = None

    def set_enabled(self, enabled: bool) -> None:
        assert self.conn is not None
        if not enabled and self.conn.ctl is not None:
            try:
                self.conn.ctl.servoStop()
            except Exception as e:
                log.warning("node '%s': servoStop failed: %s", self.name, e)

    # -- what the fault holder asks ---------------------------------------------------------------------
    def device_fault(self) -> Fault | None:
        assert self.conn is not None
        r = self.conn.recv
        return fault_of(int(r.getSafetyMode()), int(r.getRobotMode()))

    def clear_device_faults(self) -> None:
        """What a person does at the pendant, through the dashboard: close the safety popup, unlock a
        protective stop, power on and release the brakes; then wait (up to 5 s) for the controller to
        report the arm running, raising naming what still blocks (a pressed emergency stop at once)."""
        assert self.conn is not None
        import time

        d = self.conn.dashboard()
        try:
            d.closeSafetyPopup()
            d.unlockProtectiveStop()
            # a pressed emergency stop only the button clears: say so now instead of waiting for it
            pressed = "EMERGENCY_STOP" in d.safetystatus()
            if not pressed and "RUNNING" not in d.robotmode():  # asked now: the RTDE sample may be a cycle old
                d.powerOn()
                d.brakeRelease()
        finally:
            d.disconnect()
        t_end = time.monotonic() + (0.0 if pressed else 5.0)
        while (fault := self.device_fault()) is not None and time.monotonic() < t_end:
            time.sleep(0.02)
        self.faults.fault = fault
        self.check_ready()
        if self.config.control == "rtde":
            self.conn.ctl.reuploadScript()

    def read_joints(self) -> dict[str, Any]:
        assert self.conn is not None
        self.link.watch()  # a dropped link is noticed and retried here
        r = self.conn.recv
        safety, mode, scaling = int(r.getSafetyMode()), int(r.getRobotMode()), float(r.getSpeedScaling())
        fault = fault_of(safety, mode)
        if fault is not None and fault != self.faults.fault:
            self.faults.report(fault)
        if scaling < 0.999 and not self._scaling_warned and fault is None:
            log.warning("node '%s': the UR's speed slider is at %.0f %%: motion is slowed (set it to 100 %% on the "
                        "pendant)", self.name, 100 * scaling)
            self._scaling_warned = True
        sample = {"joint_pos": np.asarray(r.getActualQ(), dtype=np.float64),
                  "joint_vel": np.asarray(r.getActualQd(), dtype=np.float64),
                  "speed_scaling": scaling, "safety_mode": safety, "robot_mode": mode}
        if self.streams_poses:
            sample["eef_pose"] = from_ur(r.getActualTCPPose())
        return sample

    def _guarded(self, fn, *args: Any) -> None:
        try:
            ok = fn(*args)
        except (OSError, RuntimeError):
            self.link.lost()
            return
        if ok is False and self.conn is not None:
            fault = self.device_fault()
            if fault is not None:
                self.faults.report(fault)

    def write_joints(self, joint_pos: np.ndarray) -> None:
        assert self.conn is not None
        c = self.config
        self._guarded(self.conn.ctl.servoJ, joint_pos.tolist(), 0.0, 0.0, 1.0 / c.rate_hz, c.lookahead_time, c.gain)

    def write_pose(self, eef_pose: np.ndarray) -> None:
        assert self.conn is not None
        c = self.config
        self._guarded(self.conn.ctl.servoL, to_ur(eef_pose), 0.0, 0.0, 1.0 / c.rate_hz, c.lookahead_time, c.gain)
