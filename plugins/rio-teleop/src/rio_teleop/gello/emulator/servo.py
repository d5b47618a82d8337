"""One emulated Dynamixel XL330: its control table and a position model.

`encoder` is the shaft angle in steps, multi-turn and continuous, as the servo counts it after power
on; Present Position reads `encoder + homing offset` (int32). With torque off the shaft is where a
`hand` (t -> steps, the person moving the leader) puts it, else it stays; with torque on (position or
current-based position mode) it tracks Goal Position with a first-order lag, unless a hand holds it
(a person overpowers an XL330 at low current: the GELLO trigger's spring). The model integrates
lazily when the bus touches the servo: no thread ticks it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from .. import control_table as T
from .. import protocol as P

TAU_S = 0.05


class XL330Emulator:
    def __init__(self, servo_id: int, *, position: float = 2048.0, model: int = T.XL330_M288,
                 baudrate: int = 57600, clock: Callable[[], float] = time.monotonic):
        self.id = int(servo_id)
        self.mem = bytearray(256)
        self._put(T.MODEL_NUMBER, model)
        self._put(T.FIRMWARE_VERSION, 52)
        self._put(T.ID, self.id)
        self._put(T.BAUD_RATE, T.BAUD_CODES.get(int(baudrate), 1))
        self._put(T.RETURN_DELAY, 250)
        self._put(T.OPERATING_MODE, T.POSITION)
        self._put(T.STATUS_RETURN_LEVEL, 2)
        self._put(T.GOAL_CURRENT, 1750)
        self._put(T.PRESENT_VOLTAGE, 50)
        self._put(T.PRESENT_TEMPERATURE, 30)
        self.encoder = float(position)
        self.velocity = 0.0
        #: The user's hand: t -> encoder steps, or None to let go.
        self.hand: Callable[[float], float | None] | None = None
        #: False: the servo never answers (unplugged, another id).
        self.responsive = True
        self.clock = clock
        self._t = clock()

    # -- registers -------------------------------------------------------------------------------
    def _put(self, reg: tuple[int, int], value: int) -> None:
        self.mem[reg[0]:reg[0] + reg[1]] = P.le(value, reg[1])

    def reg(self, reg: tuple[int, int]) -> int:
        return P.signed(self.mem[reg[0]:reg[0] + reg[1]], reg[1])

    @property
    def torque_on(self) -> bool:
        return bool(self.mem[T.TORQUE_ENABLE[0]])

    def present(self) -> int:
        return int(round(self.encoder)) + self.reg(T.HOMING_OFFSET)

    def read(self, address: int, length: int) -> tuple[int, bytes]:
        """(error number, data) of a READ."""
        if address + length > len(self.mem) or length < 1:
            return P.ERR_DATA_RANGE, b""
        self.update()
        self._put(T.PRESENT_POSITION, self.present())
        v = max(-(2 ** 31), min(2 ** 31 - 1, round(self.velocity / T.RAD_S_PER_VELOCITY_UNIT)))
        self._put(T.PRESENT_VELOCITY, v)
        return 0, bytes(self.mem[address:address + length])

    def write(self, address: int, data: bytes) -> int:
        """Apply a WRITE; returns the status error number (0, or access / range errors, nothing written)."""
        end = address + len(data)
        if end > len(self.mem) or not data:
            return P.ERR_DATA_RANGE
        touched = range(address, end)
        if any(a in r for r in T.READ_ONLY for a in touched) or T.MODEL_NUMBER[0] in touched:
            return P.ERR_ACCESS
        if address < T.EEPROM_END and self.torque_on:
            return P.ERR_ACCESS  # EEPROM is locked while torque is on
        self.update()
        self.mem[address:end] = data
        return 0

    # -- physics ---------------------------------------------------------------------------------
    def update(self, t: float | None = None) -> None:
        t = self.clock() if t is None else t
        dt, self._t = max(0.0, t - self._t), t
        before = self.encoder
        pos = self.hand(t) if self.hand is not None else None
        if pos is not None:
            self.encoder = float(pos)
        elif self.torque_on and self.reg(T.OPERATING_MODE) in (T.POSITION, T.EXTENDED_POSITION, T.CURRENT_POSITION):
            goal = self.reg(T.GOAL_POSITION) - self.reg(T.HOMING_OFFSET)
            self.encoder = goal + (self.encoder - goal) * math.exp(-dt / TAU_S)
        self.velocity = (self.encoder - before) * T.RAD_PER_STEP / dt if dt > 0 else 0.0
