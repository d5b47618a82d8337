"""`DhRegisters`: a DH-Robotics AG-95 / AG-105-145 as its Modbus registers (AG series short manual,
Modbus-RTU), transport-free like `RobotiqRegisters`.

    0x0100 initialization   write 1 (initialize) or 0xA5 (full initialization)
    0x0101 force            20..100 (% of the maximum)
    0x0102 (reserved)
    0x0103 position         0..1000 (per mille of the stroke; 0 closed, 1000 open): the fingers go there
    0x0104 speed            1..100 (%)
    0x0200 init state       0 not initialized, 1 initialized, 2 initializing (read only)
    0x0201 grip state       0 moving, 1 at position, 2 object caught, 3 object dropped (read only)
    0x0202 position         0..1000, measured (read only)

Functions 3 and 4 read, 6 and 16 write; an unmapped address answers exception 2, a value out of its
range exception 3 (the driver must clip). Initialization opens the fingers fully at full speed (the
default initialization direction) and reports 1 when they are there. Position writes before that
are ignored, as on the gripper.

Test hooks: `fingers.object_width` places an object; removing it while held makes the state 3
(dropped); `power_cycle()` loses the initialization, as a brown-out does.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from rio.emulation import ILLEGAL_DATA_ADDRESS, ILLEGAL_DATA_VALUE, ModbusError

from ..dh.registers import (
    DEFAULT_SLAVE_ID,
    FORCE,
    GRIP_AT_POSITION,
    GRIP_CAUGHT,
    GRIP_DROPPED,
    GRIP_MOVING,
    GRIP_STATE,
    INIT,
    INIT_DONE,
    INIT_NONE,
    INIT_RUNNING,
    INIT_STATE,
    POSITION,
    POSITION_NOW,
    SPEED,
)
from ..models import DH_FORCE_PCT, DH_MODELS, DH_SPEED_PCT
from .slave import GripperSlave

_RANGES = {INIT: (0, 0xA5), FORCE: DH_FORCE_PCT, POSITION: (0, 1000), SPEED: DH_SPEED_PCT}
_RESERVED = 0x0102


class DhRegisters(GripperSlave):
    def __init__(self, model: str = "ag95", *, slave_id: int = DEFAULT_SLAVE_ID,
                 clock: Callable[[], float] = time.monotonic):
        super().__init__(DH_MODELS, model, slave_id, clock)
        self.holding = {INIT: 0, FORCE: 100, _RESERVED: 0, POSITION: 1000, SPEED: 100}
        self._init = INIT_NONE
        #: finger speed of the initialization run (m/s); lower it to emulate a jammed gripper
        self.init_speed = self.model.max_speed
        self._caught = False  # an object was caught since the last position command

    # -- Modbus ---------------------------------------------------------------------------------------
    def read_registers(self, function: int, address: int, count: int) -> list[int]:
        with self.lock:
            regs = {**self.holding, **self._feedback()}
            wanted = range(address, address + count)
            if not all(a in regs for a in wanted):
                raise ModbusError(ILLEGAL_DATA_ADDRESS, f"no registers 0x{address:04X}..+{count}")
            return [regs[a] for a in wanted]

    def write_registers(self, address: int, values: list[int]) -> None:
        with self.lock:
            for a, v in enumerate(values, start=address):
                if a not in self.holding:
                    raise ModbusError(ILLEGAL_DATA_ADDRESS, f"register 0x{a:04X} is not writable")
                lo, hi = _RANGES.get(a, (0, 0xFFFF))
                if not lo <= v <= hi or (a == INIT and v not in (0, 1, 0xA5)):
                    raise ModbusError(ILLEGAL_DATA_VALUE, f"0x{a:04X} takes {lo}..{hi}, got {v}")
            for a, v in enumerate(values, start=address):
                self.holding[a] = v
                self._written(a, v)

    # -- test hooks -------------------------------------------------------------------------------------
    def power_cycle(self) -> None:
        """Lose the initialization (a brown-out, a power cut): the fingers stop, position writes are
        ignored until the gripper is initialized again."""
        with self.lock:
            self._init = INIT_NONE
            self._stop()

    @property
    def init_state(self) -> int:
        """0x0200 now: 0 not initialized, 1 initialized, 2 initializing."""
        with self.lock:
            return self._feedback()[INIT_STATE]

    @property
    def speed(self) -> float:
        """The finger speed the speed register asks for (m/s)."""
        return self.holding[SPEED] / 100.0 * self.model.max_speed

    @property
    def force(self) -> float:
        """The grip force the force register asks for (N)."""
        return self.holding[FORCE] / 100.0 * self.model.force_range[1]

    # -- behaviour --------------------------------------------------------------------------------------
    def _written(self, address: int, value: int) -> None:
        if address == INIT and value in (1, 0xA5):
            self._init = INIT_RUNNING
            self.fingers.command(self.model.stroke, speed=self.init_speed)
        elif address == POSITION and self._init == INIT_DONE:
            self._caught = False
            self.fingers.command(value / 1000.0 * self.model.stroke, speed=self.speed, force=self.force)
        elif address in (SPEED, FORCE) and self._init == INIT_DONE:
            self.fingers.speed = self.speed
            self.fingers.force = self.force

    def _feedback(self) -> dict[int, int]:
        pos = self.fingers.update()
        if self._init == INIT_RUNNING and not self.fingers.moving:
            self._init = INIT_DONE
            self.fingers.command(pos, speed=self.speed, force=self.force)
        if self._init != INIT_DONE:
            grip = GRIP_MOVING if self.fingers.moving else GRIP_AT_POSITION
        elif self.fingers.object_detected:
            self._caught, grip = True, GRIP_CAUGHT
        elif self.fingers.moving:
            grip = GRIP_MOVING
        else:
            grip = GRIP_DROPPED if self._caught else GRIP_AT_POSITION
        return {INIT_STATE: self._init, GRIP_STATE: grip,
                POSITION_NOW: int(round(pos / self.model.stroke * 1000))}
