"""`robotiq.2f85`, `robotiq.2f140`, `robotiq.hande` (Modbus RTU) and `robotiq.urcap` (the UR URCap
socket): Robotiq adaptive grippers in RIO's gripper contract.

The driver is the Robotiq logic once, over a link per transport (`rtu_link`, `urcap_link`) that speaks
in register values; the gripper kind does the rest (clipping to [0, max_width], interpolation,
`max_step_m`, the watchdog, enable/disable).

- `open()` activates the gripper (rACT 0 then 1, then gSTA == 3 within `activation_timeout_s`), unless
  it already is activated without a fault: activation moves the fingers through their stroke, so a
  restart does not repeat it needlessly.
- enable = go to where the fingers are (rGTO 1, rPR = gPO); disable = stop (rGTO 0). Neither
  deactivates, so neither moves the fingers.
- each cycle reads the status and writes a command only when the position, speed or force request
  changed. Opening in m <-> 0..255 (0 = open), inverted and scaled by the model's stroke.
- a major fault (gFLT 0x0A..0x0F) stops the fingers and raises `RobotiqFault` with the manual's
  meaning; `reset_fault()` re-activates. Minor faults (temperature, communication) are logged and
  published in `fault`.

Extra state keys: `object_detected` (gOBJ 1 or 2), `fault` (gFLT), `current` (A; NaN over the URCap).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import Any, Literal

from pydantic import Field, model_validator

from rio import clock
from rio.interfaces import GripperNode, NetworkDevice, ServoBus
from rio.runtime.node import remote

from ..emulator import private
from ..errors import ActivationError, CommunicationError, RobotiqFault
from ..faults import MAJOR, MINOR, fault_class, fault_meaning, is_major
from ..linked import close_device, model_width, open_device
from ..models import ROBOTIQ_MODELS, robotiq_counts, robotiq_width, scale_to_byte
from .registers import CURRENT_PER_COUNT, DEFAULT_SLAVE_ID, STA_ACTIVE, STA_RESET, RobotiqStatus

log = logging.getLogger("rio_robotiq")

#: rFR when neither the station nor a request gives a force: the middle of the model's range
DEFAULT_FORCE_BYTE = 128
_POLL_S = 0.02


class RobotiqBase(GripperNode):
    """What both transports share. Subclasses say how to connect (`connect()`: the link, `self.device`)."""

    class Config(GripperNode.Config):
        model: Literal["2f85", "2f140", "hande"] = Field("2f85", description="2f85, 2f140 or hande")
        #: None until validated, then the model's stroke (so the base's float type holds for the kind)
        max_width: float | None = Field(  # type: ignore[assignment]
            None, gt=0, description="full opening (m); default: the model's stroke (0.085, 0.140, 0.050)")
        speed: float | None = Field(None, gt=0, description="finger speed (m/s) within the model's range "
                                                            "(2F-85: 0.02-0.15); default: its fastest")
        open_count: int = Field(0, ge=0, le=255, description="position count of the fully open fingers on this "
                                                             "unit (the manual's 0; units read a few counts in)")
        closed_count: int = Field(255, ge=0, le=255, description="position count where the fingers touch (the "
                                                                 "manual's 255; a 2F-85 often stops near 227)")
        activation_timeout_s: float = Field(15.0, gt=0, description="how long activation may take (s)")

        @model_validator(mode="after")
        def _model_defaults(self) -> Any:
            spec = ROBOTIQ_MODELS[self.model]
            self.max_width = model_width(self.max_width, spec)
            lo, hi = spec.speed_range
            if self.speed is not None and not lo - 1e-9 <= self.speed <= hi + 1e-9:
                raise ValueError(f"speed {self.speed} m/s is outside the {spec.label}'s range {lo}..{hi} m/s")
            if self.open_count >= self.closed_count:
                raise ValueError(f"open_count {self.open_count} must be below closed_count {self.closed_count}")
            return self

    # -- transport: `connect()` returns the link (`status`, `activate`, `go`, `stop`, `close`, `where`) ---------
    def connect(self) -> Any:
        raise NotImplementedError

    # -- contract ---------------------------------------------------------------------------------------
    def setup(self) -> None:
        super().setup()
        self.device: Any = None  # the open link, None while closed
        self._emulator: Any = None  # the private emulator behind an "emulator" address
        self.spec = ROBOTIQ_MODELS[self.config.model]
        self.example_data = {**(self.example_data or {}), "object_detected": False, "fault": 0, "current": 0.0}
        c = self.config
        self._counts = (int(c.open_count), int(c.closed_count))
        speed = c.speed if c.speed is not None else self.spec.max_speed
        self._speed_byte = scale_to_byte(speed, *self.spec.speed_range)
        self._sent: tuple[int, int, int] | None = None  # the last go() request, so unchanged ones are not resent
        self._minor = 0  # the minor fault last logged

    def open(self) -> None:
        open_device(self, self.connect, lambda: self._activate(force=False))

    def close(self) -> None:
        close_device(self)

    def read_width(self) -> dict[str, Any]:
        st = self.device.status(full=False)
        self._check_fault(st.gFLT)
        return {"width": self._width(st.gPO), "object_detected": st.object_detected, "fault": int(st.gFLT),
                "current": math.nan if st.gCU is None else st.gCU * CURRENT_PER_COUNT}

    def write_width(self, width: float, force: float) -> None:
        self._go(robotiq_counts(width, self.spec.stroke, *self._counts), force)

    def set_enabled(self, enabled: bool) -> None:
        self._sent = None
        if enabled:  # go to where the fingers are: activated and following, nothing moves
            st = self.device.status(full=False)
            self._check_fault(st.gFLT)
            self._go(st.gPO, self.force)
        else:
            self.device.stop()

    # -- remote API -------------------------------------------------------------------------------------
    @remote
    def reset_fault(self) -> bool:
        """Clear a fault by re-activating (rACT 0 then 1: the fingers run their activation motion), then
        hold where they are if the node is enabled."""
        self._activate(force=True)
        self._minor, self._sent = 0, None
        if self.enabled:
            self.enable()
        return True

    # -- helpers ----------------------------------------------------------------------------------------
    def _width(self, counts: int) -> float:
        return robotiq_width(counts, self.spec.stroke, *self._counts)

    def _force_byte(self, force: float) -> int:
        if force is None or math.isnan(force):
            return DEFAULT_FORCE_BYTE
        return scale_to_byte(force, *self.spec.force_range)

    def _go(self, counts: int, force: float) -> None:
        request = (int(counts), self._speed_byte, self._force_byte(force))
        if request != self._sent:
            self.device.go(*request)
            self._sent = request

    def _check_fault(self, code: int) -> None:
        kind = fault_class(code)
        if kind == MAJOR:
            self._hold()
            raise RobotiqFault(self.spec.label, self.device.where, code)
        if kind == MINOR and code != self._minor:
            log.warning("%s on %s: minor fault 0x%02X: %s", self.spec.label, self.device.where, code,
                        fault_meaning(code))
        self._minor = code if kind == MINOR else 0

    def _hold(self) -> None:
        """Stop the fingers and freeze the kind's goal: nothing moves until a reset and a new command."""
        self._sent = None
        try:
            self.device.stop()
        except CommunicationError as e:
            log.warning("%s on %s: could not stop after a fault: %s", self.spec.label, self.device.where, e)
        if self._commander is not None:
            self._commander.hold(clock.now())

    def _activate(self, force: bool) -> None:
        """rACT 0 (reset, clears faults), rACT 1, then wait for gSTA == 3; skipped when already active."""
        st = self.device.status(full=True)
        if not force and st.activated and not is_major(st.gFLT):
            return
        self.device.activate(False)
        self._wait(lambda s: s.gSTA == STA_RESET, 2.0, "resetting")
        self.device.activate(True)
        st = self._wait(lambda s: s.gSTA == STA_ACTIVE, float(self.config.activation_timeout_s), "activating")
        if is_major(st.gFLT):
            raise RobotiqFault(self.spec.label, self.device.where, st.gFLT)

    def _wait(self, done: Callable[[RobotiqStatus], bool], timeout: float, what: str) -> RobotiqStatus:
        t_end = time.monotonic() + timeout
        while True:
            st = self.device.status(full=True)
            if done(st) or is_major(st.gFLT):
                return st
            if time.monotonic() > t_end:
                raise ActivationError(
                    f"{self.spec.label} on {self.device.where} did not finish {what} within {timeout:.3g} s (gACT "
                    f"{st.gACT}, gSTA {st.gSTA}, fault 0x{st.gFLT:02X}: {fault_meaning(st.gFLT)}); check the 24 V "
                    "supply and that the fingers can move freely")
            time.sleep(_POLL_S)


class RobotiqGripper(RobotiqBase):
    """A Robotiq 2F-85, 2F-140 or Hand-E on a Modbus RTU line (115200 8N1, slave id 9 by default)."""

    class Config(ServoBus, RobotiqBase.Config):
        defaults = {"baudrate": 115200}  # Robotiq's
        slave_id: int = Field(DEFAULT_SLAVE_ID, ge=1, le=247, description="Modbus slave id (Robotiq's default: 9)")
        timeout_s: float = Field(0.2, gt=0, description="how long to wait for an answer (s)")

    def connect(self) -> Any:
        from .rtu_link import RobotiqRtuLink

        c, path = self.config, self.config.port
        if private.is_emulator(path):
            self._emulator = private.robotiq_rtu(c.model, c.slave_id)
            path = self._emulator.port
        return RobotiqRtuLink(path, c.slave_id, baudrate=c.baudrate, timeout_s=c.timeout_s, retries=c.retries,
                              label=self.spec.label).open()


class RobotiqUrcapGripper(RobotiqBase):
    """A Robotiq gripper on a UR arm, through the Robotiq URCap's socket on the controller."""

    class Config(NetworkDevice, RobotiqBase.Config):
        renamed = {"host": "ip"}
        renamed_values = {"ip": {"virtual": "emulator"}}  # "virtual" before the stand-ins had one word each
        ip: str = Field(description='the UR controller\'s address (an IPv4 address or a host name), or "emulator" '
                                    "for an emulated URCap")  # a socket's address: host names too
        port: int = Field(63352, ge=1, le=65535, description="the URCap's gripper socket")
        timeout_s: float = Field(1.0, gt=0, description="how long to wait for a reply (s)")

    def connect(self) -> Any:
        from .urcap_link import RobotiqUrcapLink

        c, host, port = self.config, self.config.ip, self.config.port
        if private.is_emulator(host):
            self._emulator = private.robotiq_urcap(c.model)
            host, port = self._emulator.host, self._emulator.port
        return RobotiqUrcapLink(host, port, timeout_s=c.timeout_s, label=self.spec.label,
                                connect_timeout_s=c.connect_timeout_s).open()
