"""`GripperSlave`: what the register models of both grippers share: a Modbus register slave
(`rio.emulation.RegisterSlave`) whose registers drive the model's fingers (`rio.emulation.FingerModel`,
full stroke open at power-on, moving at the model's top speed unless a register says otherwise)."""

from __future__ import annotations

import time
from collections.abc import Callable

from rio.emulation import FingerModel, RegisterSlave

from ..models import GripperModel


class GripperSlave(RegisterSlave):
    def __init__(self, models: dict[str, GripperModel], model: str, slave_id: int,
                 clock: Callable[[], float] = time.monotonic):
        super().__init__(slave_id)
        if model not in models:
            raise ValueError(f"unknown gripper model {model!r}; known: {sorted(models)}")
        self.model = models[model]
        #: the fingers (opening in m, 0 = closed); `fingers.object_width` places an object
        self.fingers = FingerModel(self.model.stroke, speed=self.model.max_speed, clock=clock)

    @property
    def position(self) -> float:
        """The opening now (m)."""
        with self.lock:
            return self.fingers.update()

    def _stop(self) -> None:
        """The fingers stop where they are."""
        self.fingers.command(self.fingers.update())
