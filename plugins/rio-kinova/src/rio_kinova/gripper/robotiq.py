"""`kinova.robotiq_2f85`: the Robotiq 2F-85 on a Gen3's interface module, through the base
(`Base.SendGripperCommand` in GRIPPER_POSITION mode, `Base.GetMeasuredGripperMovement`).

The base takes the finger position as 0 (open) .. 1 (closed); RIO's opening in m is
(1 - position) * max_width. It shares the arm's kortex session (one per process and base) and its
held-on-fault behaviour, and re-sends a goal only when it moved by more than `deadband_m`.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from rio.interfaces import GripperNode

from ..link import KortexConfig, close_session, guarded, hold_faults_and_drops, open_session, watch
from ..models import ARMS, get_arm

Model = Literal["gen3", "gen3_6dof", "gen3_lite"]


class KinovaRobotiq(GripperNode):
    class Config(KortexConfig, GripperNode.Config):
        defaults = {"rate_hz": Field(20.0, le=100), "max_width": 0.085}  # one base round trip a cycle; the 2F-85
        model: Model = Field("gen3", description=f"the arm it is mounted on: {', '.join(ARMS)}")
        deadband_m: float = Field(0.001, ge=0, description="re-send the goal only when it changed more than this (m)")

    def setup(self) -> None:
        super().setup()
        self.kinova = get_arm(self.config.model)
        hold_faults_and_drops(self)
        self._sent: float | None = None
        self._last = float(self.config.max_width)

    def open(self) -> None:
        open_session(self)

    def close(self) -> None:
        close_session(self)

    def set_enabled(self, enabled: bool) -> None:
        self._sent = None

    def read_width(self) -> dict[str, Any]:
        s = self.session
        assert s is not None
        watch(self)  # a lost session is noticed and reopened here
        req = s.pb.Base_pb2.GripperRequest()
        req.mode = s.pb.Base_pb2.GRIPPER_POSITION
        g = guarded(self, s.base.GetMeasuredGripperMovement, req)
        if g is not None and len(g.finger):
            self._last = (1.0 - float(g.finger[0].value)) * self.width
        return {"width": self._last}

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
        guarded(self, s.base.SendGripperCommand, cmd)

