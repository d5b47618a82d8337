"""`dh.ag95`, `dh.ag105`: DH-Robotics AG-95 (AG-160-95) and AG-105-145 adaptive grippers over Modbus RTU,
in RIO's gripper contract.

- `open()` initializes the gripper when its init state is not 1 (write 1 to 0x0100, wait for 0x0200
  to read 1 within `init_timeout_s`): initialization opens the fingers fully, so a restart of an
  initialized gripper skips it. Speed (0x0104) is set from `speed`.
- each cycle reads init state, grip state and position in one transaction (function 3 from 0x0200) and
  writes force (0x0101) and position (0x0103) only when they change (function 6).
- disable = command the measured position (the gripper has no stop bit); enable holds it the same way.
- a gripper that loses its initialization mid-run (power cut) stops being commanded and raises
  `GripperFault`; `reset_fault()` initializes it again.

Extra state keys: `object_detected` (grip state 2), `object_dropped` (grip state 3: an object slipped
out after a grasp). DH reports no motor current or fault code over these registers.
"""

from __future__ import annotations

import math
import time
from typing import Any, Literal

from pydantic import Field, model_validator

from rio import clock
from rio.interfaces import GripperNode, ServoBus
from rio.runtime.node import remote

from ..emulator import private
from ..errors import ActivationError, GripperFault
from ..linked import close_device, model_width, open_device
from ..models import DH_MODELS, dh_force_pct, dh_permille, dh_speed_pct, dh_width
from ..rtu import RtuClient
from .registers import (
    DEFAULT_SLAVE_ID,
    FORCE,
    GRIP_CAUGHT,
    GRIP_DROPPED,
    INIT,
    INIT_DONE,
    INIT_STATE,
    INIT_STATES,
    POSITION,
    SPEED,
)

#: force register when neither the station nor a request gives a force (per cent)
DEFAULT_FORCE_PCT = 50
_POLL_S = 0.02


class DhGripper(GripperNode):
    class Config(ServoBus, GripperNode.Config):
        defaults = {"baudrate": 115200}  # DH's
        model: Literal["ag95", "ag105"] = Field("ag95", description="ag95 (AG-160-95) or ag105 (AG-105-145)")
        slave_id: int = Field(DEFAULT_SLAVE_ID, ge=1, le=247, description="Modbus slave id (DH's default: 1)")
        timeout_s: float = Field(0.2, gt=0, description="how long to wait for an answer (s)")
        #: None until validated, then the model's stroke (so the base's float type holds for the kind)
        max_width: float | None = Field(  # type: ignore[assignment]
            None, gt=0, description="full opening (m); default: the model's stroke (0.095, 0.145)")
        speed: float | None = Field(None, gt=0, description="finger speed (m/s); default: the fastest")
        init_timeout_s: float = Field(15.0, gt=0, description="how long initialization may take (s)")

        @model_validator(mode="after")
        def _model_defaults(self) -> Any:
            spec = DH_MODELS[self.model]
            self.max_width = model_width(self.max_width, spec)
            if self.speed is not None and self.speed > spec.max_speed + 1e-9:
                raise ValueError(f"speed {self.speed} m/s is beyond the {spec.label}'s {spec.max_speed:.3f} m/s")
            return self

    def setup(self) -> None:
        super().setup()
        self.spec = DH_MODELS[self.config.model]
        self.example_data = {**(self.example_data or {}), "object_detected": False, "object_dropped": False}
        self.device: RtuClient | None = None  # the open Modbus client, None while closed
        self._emulator: Any = None  # the private emulator behind an "emulator" port
        self._sent: dict[int, int] = {}  # register -> last value written

    # -- lifecycle --------------------------------------------------------------------------------------
    def connect(self) -> RtuClient:
        c, path = self.config, self.config.port
        if private.is_emulator(path):
            self._emulator = private.dh_rtu(c.model, c.slave_id)
            path = self._emulator.port
        return RtuClient(path, c.slave_id, baudrate=c.baudrate, timeout_s=c.timeout_s, retries=c.retries,
                         label=self.spec.label).open()

    def open(self) -> None:
        open_device(self, self.connect, lambda: self._initialize(force=False))

    def close(self) -> None:
        close_device(self)

    # -- driver hooks -----------------------------------------------------------------------------------
    def read_width(self) -> dict[str, Any]:
        assert self.device is not None
        init, grip, permille = self.device.read(INIT_STATE, 3)
        if init != INIT_DONE:
            self._hold()
            raise GripperFault(f"{self.spec.label} on {self.device.where} lost its initialization (init state "
                               f"{init}: {INIT_STATES.get(init, 'unknown')}), as after a power cut; the fingers are no "
                               "longer commanded: call reset_fault() (or restart the node) to initialize it again",
                               code=init)
        return {"width": dh_width(permille, self.spec.stroke), "object_detected": grip == GRIP_CAUGHT,
                "object_dropped": grip == GRIP_DROPPED}

    def write_width(self, width: float, force: float) -> None:
        pct = DEFAULT_FORCE_PCT if math.isnan(force) else dh_force_pct(force, self.spec.force_range[1])
        self._write(FORCE, pct)  # before the position, so the move uses it
        self._write(POSITION, dh_permille(width, self.spec.stroke))

    def set_enabled(self, enabled: bool) -> None:
        """No stop bit: on and off both command the measured position, so the fingers stay."""
        assert self.device is not None
        self._sent.pop(POSITION, None)
        self._write(POSITION, self.device.read(INIT_STATE, 3)[2])

    # -- remote API -------------------------------------------------------------------------------------
    @remote
    def reset_fault(self) -> bool:
        """Initialize again (the fingers open fully), then hold there if the node is enabled."""
        self._initialize(force=True)
        if self.enabled:
            self.enable()
        return True

    # -- helpers ----------------------------------------------------------------------------------------
    def _write(self, register: int, value: int) -> None:
        assert self.device is not None
        if self._sent.get(register) != value:
            self.device.write_one(register, value)
            self._sent[register] = value

    def _initialize(self, force: bool) -> None:
        assert self.device is not None
        self._sent.clear()
        if force or self.device.read(INIT_STATE, 1)[0] != INIT_DONE:
            self.device.write_one(INIT, 1)
            t_end = time.monotonic() + float(self.config.init_timeout_s)
            time.sleep(_POLL_S)  # the state may still read 1 from before the request
            while (state := self.device.read(INIT_STATE, 1)[0]) != INIT_DONE:
                if time.monotonic() > t_end:
                    raise ActivationError(
                        f"{self.spec.label} on {self.device.where} did not finish initializing within "
                        f"{self.config.init_timeout_s:.3g} s (init state {state}: "
                        f"{INIT_STATES.get(state, 'unknown')}); check the 24 V supply and that the fingers can move "
                        "freely")
                time.sleep(_POLL_S)
        speed = self.config.speed if self.config.speed is not None else self.spec.max_speed
        self._write(SPEED, dh_speed_pct(speed, self.spec.max_speed))

    def _hold(self) -> None:
        self._sent.clear()
        if self._commander is not None:
            self._commander.hold(clock.now())
