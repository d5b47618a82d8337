"""`ur.ur3e|ur5e|ur7e|ur10e|ur12e|ur16e|ur20|ur30`: a Universal Robots arm through ur-rtde.

Hardware logic only; the arm kind (`rio.interfaces.ArmNode`) owns the cycle, the interpolation and the
safety. Each tick copies the latest RTDE state and streams one servo target: joint goals with `servoJ`,
end-effector goals with `servoL` (the controller's own Cartesian servo; `eef_control = "ik"` solves IK on
RIO's model instead). servoJ executes only the newest target, smoothed over `lookahead_time`, so the
kind's commander (clip, step limit, watchdog) is what shapes the motion.

A protective or emergency stop, a power-off or brakes on do not end the node: it reports `fault_code`,
refuses commands naming the fault and holds; `clear_faults()` (dashboard: close the popup, unlock, power
on, release the brakes) brings it back holding where the arm is. Faults are held the core way
(`rio.interfaces.FaultHolding`); this adds the UR's hooks and its connection drops.
"""

from __future__ import annotations

import logging
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator

from rio.control import quat_to_rotvec, rotvec_to_quat
from rio.interfaces import FAULT_KEYS, ArmNode, Fault, FaultHolding, ModelTableArm

from ..description import description
from ..faults import fault_of
from ..link import URLink
from ..models import ARMS, get_arm

log = logging.getLogger("rio_ur")
Model = Literal["ur3e", "ur5e", "ur7e", "ur10e", "ur12e", "ur16e", "ur20", "ur30"]


def from_ur(pose: Any) -> np.ndarray:
    """UR's [x, y, z, rx, ry, rz] (rotation vector) -> RIO's [x, y, z, qw, qx, qy, qz]."""
    p = np.asarray(pose, dtype=np.float64)
    return np.concatenate([p[:3], rotvec_to_quat(p[3:])])


def to_ur(pose: np.ndarray) -> list[float]:
    return [*map(float, pose[:3]), *map(float, quat_to_rotvec(pose[3:]))]


class URArm(FaultHolding, ModelTableArm, ArmNode):
    lookup_model = staticmethod(get_arm)
    describe_model = staticmethod(description)

    class Config(ArmNode.Config):
        ip: str = Field(description="controller IP address (pendant: Settings > System > Network)")
        model: Model = Field("ur5e", description=f"which arm: {', '.join(ARMS)}")
        control: Literal["rtde", "emulator"] = Field(
            "rtde", description='"rtde": ur-rtde\'s control interface (the real arm); "emulator": the emulator\'s '
                                "servo port (`rio ur emulator`, the virtual stations)")
        rate_hz: float = Field(500.0, gt=0, le=500, description="servo targets per second (the controller runs "
                                                                "at 500 Hz)")
        max_step_rad: float = Field(0.006, gt=0, description="largest joint goal change per cycle (rad): 3 rad/s "
                                                             "at 500 Hz")
        max_step_m: float = Field(0.002, gt=0, description="largest tool travel per cycle (m): 1 m/s at 500 Hz")
        max_step_eef_rad: float = Field(0.006, gt=0, description="largest tool rotation per cycle (rad)")
        lookahead_time: float = Field(0.1, ge=0.03, le=0.2, description="servoJ/servoL smoothing (s)")
        gain: float = Field(300.0, ge=100, le=2000, description="servoJ/servoL proportional gain")
        eef_control: Literal["controller", "ik"] = Field(
            "controller", description='end-effector targets through servoL ("controller") or RIO\'s IK ("ik")')
        tcp_offset: tuple[float, float, float, float, float, float] | None = Field(
            None, description="tool centre point from the flange [x, y, z (m), rx, ry, rz (rotation vector)], set "
                              "on the controller at start; default: as set on the pendant for servoL, the flange "
                              "for RIO's model")
        connect_timeout_s: float = Field(5.0, ge=0, description="keep trying to connect this long at start (s)")

        @field_validator("ip")
        @classmethod
        def _ipv4(cls, v: str) -> str:
            import ipaddress

            try:
                return str(ipaddress.IPv4Address(v.strip()))
            except ValueError:
                raise ValueError(f"'{v}' is not an IPv4 address like 192.168.1.102") from None

    def setup(self) -> None:
        super().setup()
        self.arm = get_arm(self.config.model)
        self.link: URLink | None = None
        self.fault = None
        self.device_label = f"UR at {self.config.ip}"
        self._scaling_warned = False
        self.example_data = {**self.example_data, **FAULT_KEYS, "speed_scaling": 1.0,
                             "safety_mode": 1, "robot_mode": 7}

    @property
    def streams_poses(self) -> bool:
        return self.config.eef_control == "controller"

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.link = URLink(c.ip, c.control, c.rate_hz, c.connect_timeout_s)
        self.link.open()
        if c.tcp_offset is not None:
            self.link.ctl.setTcp(list(c.tcp_offset))

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
            self.link = None

    def set_enabled(self, enabled: bool) -> None:
        assert self.link is not None
        if enabled:
            self.check_device_fault()
        elif self.link.ctl is not None:
            try:
                self.link.ctl.servoStop()
            except Exception as e:
                log.warning("node '%s': servoStop failed: %s", self.name, e)

    # -- FaultHolding hooks -----------------------------------------------------------------------------
    def link_up(self) -> bool:
        return self.link is not None and self.link.connected

    def device_fault(self) -> Fault | None:
        assert self.link is not None
        r = self.link.recv
        return fault_of(int(r.getSafetyMode()), int(r.getRobotMode()))

    def clear_device_faults(self) -> None:
        """What a person does at the pendant, through the dashboard: close the safety popup, unlock a
        protective stop, power on and release the brakes; then wait (up to 5 s) for the controller to
        report the arm running, raising naming what still blocks (a pressed emergency stop at once)."""
        assert self.link is not None
        import time

        d = self.link.dashboard()
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
        self.fault = fault
        self.check_ready()
        if self.config.control == "rtde":
            self.link.ctl.reuploadScript()

    def read_joints(self) -> dict[str, Any]:
        link = self.link
        assert link is not None
        if not link.connected:
            self.on_lost()
            link.reconnect()
        if link.connected:
            self.on_restored()
        r = link.recv
        safety, mode, scaling = int(r.getSafetyMode()), int(r.getRobotMode()), float(r.getSpeedScaling())
        fault = fault_of(safety, mode)
        if fault is not None and fault != self.fault:
            self.on_fault(fault)
        if scaling < 0.999 and not self._scaling_warned and fault is None:
            log.warning("node '%s': the UR's speed slider is at %.0f %%: motion is slowed (set it to 100 %% on the "
                        "pendant)", self.name, 100 * scaling)
            self._scaling_warned = True
        sample = {"joint_pos": np.asarray(r.getActualQ(), dtype=np.float64),
                  "joint_vel": np.asarray(r.getActualQd(), dtype=np.float64),
                  **self.fault_status(),
                  "speed_scaling": scaling, "safety_mode": safety, "robot_mode": mode}
        if self.streams_poses:
            sample["eef_pose"] = from_ur(r.getActualTCPPose())
        return sample

    def _guarded(self, fn, *args: Any) -> None:
        try:
            ok = fn(*args)
        except (OSError, RuntimeError):
            self.on_lost()
            return
        if ok is False and self.link is not None:
            fault = self.device_fault()
            if fault is not None:
                self.on_fault(fault)

    def write_joints(self, joint_pos: np.ndarray) -> None:
        assert self.link is not None
        c = self.config
        self._guarded(self.link.ctl.servoJ, joint_pos.tolist(), 0.0, 0.0, 1.0 / c.rate_hz, c.lookahead_time, c.gain)

    def write_pose(self, eef_pose: np.ndarray) -> None:
        assert self.link is not None
        c = self.config
        self._guarded(self.link.ctl.servoL, to_ur(eef_pose), 0.0, 0.0, 1.0 / c.rate_hz, c.lookahead_time, c.gain)
