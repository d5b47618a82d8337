"""Register models of the grippers, transport-free: `RobotiqRegisters` here, `DhRegisters` (re-exported
from `dh.py`). Each is a `GripperSlave`: a Modbus slave (`rio.emulation.RegisterSlave`: `handle(frame)`,
frames without CRC) whose registers drive a `rio.emulation.FingerModel`, so the RTU device on a pty,
the URCap server and other plugins' emulators (a Robotiq on an arm's tool RS-485) share one behaviour.

`RobotiqRegisters` follows the 2F-85/2F-140/Hand-E manuals' register map (see
`rio_robotiq.robotiq.registers`):

- output block 0x03E8..0x03EF (read/write), input block 0x07D0..0x07D7 (read only); functions 3 and 4
  read either block, 6 and 16 write the output block; other addresses answer exception 2;
- a rising edge of rACT clears the fault and activates: gSTA 1 for `activation_s`, then 3 (the real
  gripper runs its fingers through the stroke meanwhile; here they stay put, so a test's start pose is
  where it left them). rACT 0 resets (gSTA 0, fault cleared, fingers stopped);
- activated with rGTO 1, the fingers go to rPR at rSP (linear over the model's speed range); rGTO 0
  stops them. gOBJ: 0 moving (or rGTO 0: "ignore"), 2 stopped on an object while closing, 3 arrived;
- priority faults as the gripper raises them: 0x07 for rGTO without rACT, 0x05 for a move requested
  during activation (it starts when activation ends);
- `inject_fault(code)`: a major fault (0x0A..0x0F) stops the fingers and refuses motion until rACT
  rises again; a minor one (0x08, 0x09) is only reported;
- gCU (10 mA per count): 0 at rest, 100 mA moving, 100 mA + rFR / 4 counts holding an object. An
  emulator's choice: the manual gives no model of the current.

Place an object with `fingers.object_width = 0.03` (m): closing stops there and gOBJ turns 2.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rio.emulation import ILLEGAL_DATA_ADDRESS, ModbusError, in_block

from ..faults import is_major
from ..models import ROBOTIQ_MODELS, byte_to_scale
from ..robotiq.registers import (
    ACT,
    ARD,
    ATR,
    BLOCK_REGISTERS,
    DEFAULT_SLAVE_ID,
    GTO,
    INPUT_ADDRESS,
    OBJ_AT_POSITION,
    OBJ_CONTACT_CLOSING,
    OBJ_MOVING,
    OUTPUT_ADDRESS,
    STA_ACTIVATING,
    STA_ACTIVE,
    STA_RESET,
)
from .slave import GripperSlave

#: the output fields, as the URCap names them and as register bits/bytes
REQUEST_FIELDS = ("rACT", "rGTO", "rATR", "rARD", "rPR", "rSP", "rFR")


class RobotiqRegisters(GripperSlave):
    def __init__(self, model: str = "2f85", *, slave_id: int = DEFAULT_SLAVE_ID, activation_s: float = 0.1,
                 clock: Callable[[], float] = time.monotonic):
        super().__init__(ROBOTIQ_MODELS, model, slave_id, clock)
        self.clock = clock
        self.activation_s = float(activation_s)
        self.output = [0] * BLOCK_REGISTERS
        self.fault = 0
        self.gsta = STA_RESET
        self._activation_end: float | None = None

    # -- Modbus ---------------------------------------------------------------------------------------
    def read_registers(self, function: int, address: int, count: int) -> list[int]:
        with self.lock:
            self._tick()
            if in_block(address, count, OUTPUT_ADDRESS, BLOCK_REGISTERS):
                return self.output[address - OUTPUT_ADDRESS:address - OUTPUT_ADDRESS + count]
            if in_block(address, count, INPUT_ADDRESS, BLOCK_REGISTERS):
                regs = self._input_registers()
                return regs[address - INPUT_ADDRESS:address - INPUT_ADDRESS + count]
        raise ModbusError(ILLEGAL_DATA_ADDRESS, f"no registers 0x{address:04X}..+{count}")

    def write_registers(self, address: int, values: list[int]) -> None:
        if not in_block(address, len(values), OUTPUT_ADDRESS, BLOCK_REGISTERS):
            raise ModbusError(ILLEGAL_DATA_ADDRESS, f"registers 0x{address:04X}..+{len(values)} are not writable")
        with self.lock:
            self._tick()
            was_active = self.rACT
            self.output[address - OUTPUT_ADDRESS:address - OUTPUT_ADDRESS + len(values)] = values
            self._apply(was_active)

    # -- the request, by field (the URCap server's view) -----------------------------------------------
    @property
    def rACT(self) -> int:
        return int(bool(self.output[0] >> 8 & ACT))

    @property
    def rGTO(self) -> int:
        return int(bool(self.output[0] >> 8 & GTO))

    @property
    def rPR(self) -> int:
        return self.output[1] & 0xFF

    @property
    def rSP(self) -> int:
        return self.output[2] >> 8

    @property
    def rFR(self) -> int:
        return self.output[2] & 0xFF

    def request(self) -> dict[str, int]:
        action = self.output[0] >> 8
        return {"rACT": self.rACT, "rGTO": self.rGTO, "rATR": int(bool(action & ATR)),
                "rARD": int(bool(action & ARD)), "rPR": self.rPR, "rSP": self.rSP, "rFR": self.rFR}

    def set_request(self, **fields: int) -> None:
        """Change some output fields (`rPR=100, rGTO=1`), as a register write would."""
        unknown = set(fields) - set(REQUEST_FIELDS)
        if unknown:
            raise ValueError(f"unknown request fields {sorted(unknown)}; known: {REQUEST_FIELDS}")
        with self.lock:
            r = {**self.request(), **{k: int(v) for k, v in fields.items()}}
            action = (ACT * bool(r["rACT"]) | GTO * bool(r["rGTO"]) | ATR * bool(r["rATR"])
                      | ARD * bool(r["rARD"]))
            regs = [action << 8, r["rPR"] & 0xFF, (r["rSP"] & 0xFF) << 8 | r["rFR"] & 0xFF]
            self.write_registers(OUTPUT_ADDRESS, regs)

    def status(self) -> dict[str, int]:
        """The input fields: gACT gGTO gSTA gOBJ gFLT gPR gPO gCU."""
        with self.lock:
            self._tick()
            return self._status()

    # -- test hooks -------------------------------------------------------------------------------------
    def inject_fault(self, code: int) -> None:
        """Raise fault `code` (gFLT) as the gripper would; 0 clears a minor one."""
        with self.lock:
            self._tick()
            self.fault = int(code)
            if is_major(self.fault):
                self._stop()

    @property
    def speed(self) -> float:
        """The finger speed rSP asks for (m/s)."""
        return byte_to_scale(self.rSP, *self.model.speed_range)

    @property
    def force(self) -> float:
        """The grip force rFR asks for (N)."""
        return byte_to_scale(self.rFR, *self.model.force_range)

    @property
    def activated(self) -> bool:
        with self.lock:
            self._tick()
            return bool(self.rACT) and self.gsta == STA_ACTIVE

    # -- behaviour --------------------------------------------------------------------------------------
    def _tick(self) -> None:
        if self.gsta == STA_ACTIVATING and self._activation_end is not None and self.clock() >= self._activation_end:
            self.gsta, self._activation_end = STA_ACTIVE, None
            self._apply(True)  # a move requested during activation starts now

    def _apply(self, was_active: int) -> None:
        if not self.rACT:  # reset: clears the fault, stops
            self.gsta, self._activation_end, self.fault = STA_RESET, None, 0
            self._stop()
            if self.rGTO:
                self.fault = 0x07  # the activation bit must be set before the action
            return
        if not was_active:  # rising edge of rACT: activate
            self.fault, self.gsta = 0, STA_ACTIVATING
            self._activation_end = self.clock() + self.activation_s
            self._stop()
        if self.gsta != STA_ACTIVE:
            if self.rGTO:
                self.fault = 0x05  # action delayed until the activation completes
            return
        if is_major(self.fault):
            self._stop()
            return
        if self.fault in (0x05, 0x07):
            self.fault = 0
        if self.rGTO:
            width = (1.0 - self.rPR / 255.0) * self.model.stroke
            self.fingers.command(width, speed=self.speed, force=self.force)
        else:
            self._stop()

    def _status(self) -> dict[str, Any]:
        pos = self.fingers.update()
        following = bool(self.rACT and self.rGTO and self.gsta == STA_ACTIVE and not is_major(self.fault))
        detected = following and self.fingers.object_detected
        if not following:
            obj = OBJ_MOVING  # gOBJ is to be ignored while gGTO is 0
        elif detected:
            obj = OBJ_CONTACT_CLOSING
        else:
            obj = OBJ_MOVING if self.fingers.moving else OBJ_AT_POSITION
        current = 10 + self.rFR // 4 if detected else 10 if following and self.fingers.moving else 0
        return {"gACT": self.rACT, "gGTO": self.rGTO, "gSTA": self.gsta, "gOBJ": obj, "gFLT": self.fault,
                "gPR": self.rPR, "gPO": int(round((1.0 - pos / self.model.stroke) * 255)), "gCU": current}

    def _input_registers(self) -> list[int]:
        s = self._status()
        status_byte = s["gACT"] | s["gGTO"] << 3 | s["gSTA"] << 4 | s["gOBJ"] << 6
        regs = [status_byte << 8, (s["gFLT"] & 0x0F) << 8 | s["gPR"], s["gPO"] << 8 | s["gCU"]]
        return regs + [0] * (BLOCK_REGISTERS - len(regs))


from .dh import DhRegisters  # noqa: E402  (both register models, one import path)

__all__ = ["RobotiqRegisters", "DhRegisters"]
