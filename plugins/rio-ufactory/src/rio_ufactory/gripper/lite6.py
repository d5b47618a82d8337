"""`ufactory.lite6_gripper` and `ufactory.vacuum`: tool-GPIO end effectors, on or off.

The Lite 6 gripper is pneumatic-style open/close with no position sensor, and the vacuum gripper is a
suction cup: both are driven as grippers so teleop's gripper button and a policy's gripper action work
unchanged. A goal below half the opening closes (sucks), above opens (releases). The Lite 6 gripper's
`width` is the last commanded state (it cannot be measured); the vacuum's `object_detected` is its
pressure switch.
"""

from __future__ import annotations

from pydantic import Field

from .base import ToolGripper


class Lite6Gripper(ToolGripper):
    class Config(ToolGripper.Config):
        defaults = {"max_width": 0.03, "deadband_m": 0.0}  # open or closed: every change is sent

    def setup(self) -> None:
        super().setup()
        self._closed: bool | None = None  # unknown until the first goal is sent

    def read_device(self) -> tuple[float, bool]:
        return (0.0 if self._closed else self.width), False

    def send_goal(self, width: float, force: float) -> None:
        assert self.conn is not None
        closed = width < self.width / 2
        if closed != self._closed:
            self.conn.call("close_lite6_gripper" if closed else "open_lite6_gripper")
            self._closed = closed

    def enable_device(self, on: bool) -> None:
        if not on and self.conn is not None and self.conn.connected:
            self.conn.call("stop_lite6_gripper")


class VacuumGripper(ToolGripper):
    class Config(ToolGripper.Config):
        defaults = {"max_width": 0.01}  # the "opening" that means suction off
        hardware_version: int = Field(1, ge=1, le=2, description="vacuum gripper hardware version (tool IO 0/1 "
                                                                 "for 1, 3/4 for 2)")

    def setup(self) -> None:
        super().setup()
        self._on: bool | None = None  # unknown until the first goal is sent

    def read_device(self) -> tuple[float, bool]:
        assert self.conn is not None
        held = self.conn.call("get_vacuum_gripper", hardware_version=self.config.hardware_version)
        return (0.0 if self._on else self.width), bool(held == 1)

    def send_goal(self, width: float, force: float) -> None:
        assert self.conn is not None
        on = width < self.width / 2
        if on != self._on:
            self.conn.call("set_vacuum_gripper", on, wait=False, hardware_version=self.config.hardware_version)
            self._on = on
