"""`kinova.robotiq_2f85`: the Robotiq 2F-85 on a Gen3's interface module, through the base
(`Base.SendGripperCommand` in GRIPPER_POSITION mode, `Base.GetMeasuredGripperMovement`).

The base takes the finger position as 0 (open) .. 1 (closed); RIO's opening in m is
(1 - position) * max_width. It shares the arm's kortex session (one per process and base) and its
held-on-fault behaviour, and re-sends a goal only when it moved by more than `deadband_m`.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from rio.interfaces import FAULT_KEYS, GripperNode

from ..link import KortexLink, LinkConfig
from ..models import ARMS, get_arm

Model = Literal["gen3", "gen3_6dof", "gen3_lite"]


class KinovaRobotiq(KortexLink, GripperNode):
    class Config(LinkConfig, GripperNode.Config):
        model: Model = Field("gen3", description=f"the arm it is mounted on: {', '.join(ARMS)}")
        rate_hz: float = Field(20.0, gt=0, le=100, description="cycles per second (one base round trip each)")
        max_width: float = Field(0.085, gt=0, description="full opening (m): 0.085 for the 2F-85")
        deadband_m: float = Field(0.001, ge=0, description="re-send the goal only when it changed more than this (m)")

    def setup(self) -> None:
        super().setup()
        self.kinova = get_arm(self.config.model)
        self.example_data = {**self.example_data, **FAULT_KEYS}
        self._sent: float | None = None
        self._last = float(self.config.max_width)

    def open(self) -> None:
        self.open_session()

    def set_enabled(self, enabled: bool) -> None:
        if enabled:
            self.check_device_fault()
        self._sent = None

    def read_width(self) -> dict[str, Any]:
        s = self.session
        assert s is not None
        status = self.link_status()
        req = s.pb.Base_pb2.GripperRequest()
        req.mode = s.pb.Base_pb2.GRIPPER_POSITION
        g = self.guarded(s.base.GetMeasuredGripperMovement, req)
        if g is not None and len(g.finger):
            self._last = (1.0 - float(g.finger[0].value)) * self.width
        return {"position": self._last, **status, **self.fault_status()}

    def write_width(self, width: float, force: float) -> None:
        if self._sent is not None and abs(width - self._sent) <= self.config.deadband_m:
            return
        s = self.session
        assert s is not None
        self._sent = width
        cmd = s.pb.Base_pb2.GripperCommand()
        cmd.mode = s.pb.Base_pb2.GRIPPER_POSITION
        finger = cmd.gripper.finger.add()
        finger.finger_identifier, finger.value = 1, 1.0 - width / self.width
        self.guarded(s.base.SendGripperCommand, cmd)

