"""One emulated STS3215: register memory, a simple position model and the servo's own protections.

Motion model: with torque on, the position tracks the goal (clamped to the position limits) as a
first-order lag with time constant `tau`, its speed capped by `max_speed` (or by GOAL_VELOCITY when
that is set). In wheel mode (OPERATING_MODE 1, as LeKiwi's wheels run) the servo instead turns at the
signed GOAL_VELOCITY (sign-magnitude, bit 15; capped at `max_speed`), reached as a first-order lag with
the same `tau`, endlessly: the position register wraps mod 4096, PRESENT_VELOCITY reports the speed.
With torque off the joint stays where it is unless a `hand` (a function of time, the user moving the
arm) puts it somewhere. `stops` are physical end stops in encoder steps: a goal past
one leaves the servo pushing against it, its load rises (up to TORQUE_LIMIT), and once the load stays above
OVERLOAD_TORQUE for PROTECTION_TIME the servo latches the overload bit and drops its torque, as the
real one does. Temperature above MAX_TEMPERATURE and voltage outside MIN/MAX_VOLTAGE set their bits.

The model integrates lazily, in closed form, whenever the bus touches the servo, so no thread ticks
it and any elapsed time costs the same.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from ..feetech import control_table as T
from ..feetech import protocol as P

#: The STS3215 at 7.4 V turns 60 degrees in about 0.22 s: ~3100 steps/s without load.
MAX_SPEED_STEPS = 3000.0
TAU_S = 0.04
#: Load (0.1 %) per step of a blocked joint's position error: saturates 40 steps past an end stop.
BLOCKED_LOAD_PER_STEP = 25.0
#: Load (0.1 %) of free motion at full speed.
FREE_LOAD_AT_MAX_SPEED = 300.0


def _defaults(servo_id: int) -> bytearray:
    mem = bytearray(256)

    def put(reg, value):
        mem[reg[0]:reg[0] + reg[1]] = bytes(T.to_bytes(value, reg[1]))

    put(T.MODEL_NUMBER, T.STS3215_MODEL)
    put(T.ID, servo_id)
    put(T.RESPONSE_LEVEL, 1)
    put(T.RETURN_DELAY, 0)
    put(T.MIN_POSITION_LIMIT, 0)
    put(T.MAX_POSITION_LIMIT, 4095)
    put(T.MAX_TEMPERATURE, 70)
    put(T.MAX_VOLTAGE, 80)
    put(T.MIN_VOLTAGE, 40)
    put(T.MAX_TORQUE, 1000)
    put(T.P_GAIN, 32)
    put(T.D_GAIN, 32)
    put(T.PROTECTIVE_TORQUE, 20)
    put(T.PROTECTION_TIME, 20)       # 200 ms
    put(T.OVERLOAD_TORQUE, 80)       # 80 %
    put(T.TORQUE_LIMIT, 1000)
    put(T.LOCK, 1)
    return mem


class STS3215Emulator:
    def __init__(self, servo_id: int, *, position: float = 2048.0, tau: float = TAU_S,
                 max_speed: float = MAX_SPEED_STEPS, voltage: float = 7.4, temperature: float = 30.0,
                 clock: Callable[[], float] = time.monotonic):
        self.id = int(servo_id)
        self.mem = _defaults(self.id)
        #: Physical position in encoder steps (continuous; the register reads it mod 4096).
        self.encoder = float(position)
        self.velocity = 0.0
        #: Wheel mode's speed (steps/s), which lags the goal speed.
        self.wheel_speed = 0.0
        self.load = 0.0
        self.tau, self.max_speed = float(tau), float(max_speed)
        self.voltage, self.temperature = float(voltage), float(temperature)
        #: Physical end stops (encoder steps).
        self.stops = (-math.inf, math.inf)
        #: The user's hand: t -> encoder position, or None to let go. Moves the joint only with torque off.
        self.hand: Callable[[float], float | None] | None = None
        #: Error bits forced on (a broken sensor, say), OR-ed with the ones the model raises.
        self.forced_error = 0
        #: False: the servo never answers (unplugged, wrong id).
        self.responsive = True
        self.overloaded = False
        self._overload_since: float | None = None
        self.clock = clock
        self._t = clock()
        self._reg_write: tuple[int, bytes] | None = None

    # -- registers -------------------------------------------------------------------------------
    def reg(self, reg: tuple[int, int]) -> int:
        return T.from_bytes(self.mem, reg[0], reg[1])

    def _put(self, reg: tuple[int, int], value: int) -> None:
        self.mem[reg[0]:reg[0] + reg[1]] = bytes(T.to_bytes(value, reg[1]))

    @property
    def homing_offset(self) -> int:
        return T.decode_sign(self.reg(T.HOMING_OFFSET), 11)

    @property
    def torque_on(self) -> bool:
        return bool(self.mem[T.TORQUE_ENABLE[0]]) and not self.overloaded

    def present(self) -> float:
        """Position in the register's frame (after the homing offset), in [0, 4096)."""
        return (self.encoder - self.homing_offset) % T.STEPS_PER_TURN

    def read(self, address: int, length: int) -> bytes:
        self.update()
        self._refresh_present()
        return bytes(self.mem[address:address + length])

    def write(self, address: int, data: bytes) -> None:
        """A WRITE as the servo applies it: EEPROM bytes are ignored while LOCK is 1."""
        self.update()
        torque_was = self.mem[T.TORQUE_ENABLE[0]]
        for i, b in enumerate(data):
            a = address + i
            if a < T.EEPROM_END and self.mem[T.LOCK[0]] and a != T.LOCK[0]:
                continue
            if a in (T.MODEL_NUMBER[0], T.MODEL_NUMBER[0] + 1) or T.PRESENT_POSITION[0] <= a < 80:
                continue  # read-only
            self.mem[a] = b
        if not torque_was and self.mem[T.TORQUE_ENABLE[0]]:
            self.overloaded, self._overload_since = False, None  # re-enabling torque clears the latch

    def reg_write(self, address: int, data: bytes) -> None:
        self._reg_write = (address, bytes(data))

    def action(self) -> None:
        if self._reg_write is not None:
            self.write(*self._reg_write)
            self._reg_write = None

    def error_bits(self) -> int:
        bits = self.forced_error
        if self.overloaded:
            bits |= P.ERR_OVERLOAD
        if self.temperature > self.reg(T.MAX_TEMPERATURE):
            bits |= P.ERR_OVERHEAT
        if not self.reg(T.MIN_VOLTAGE) <= round(self.voltage * 10) <= self.reg(T.MAX_VOLTAGE):
            bits |= P.ERR_VOLTAGE
        return bits

    def _refresh_present(self) -> None:
        self._put(T.PRESENT_POSITION, int(round(self.present())) % T.STEPS_PER_TURN)
        self._put(T.PRESENT_VELOCITY, T.encode_sign(int(round(max(-32767.0, min(32767.0, self.velocity)))), 15))
        self._put(T.PRESENT_LOAD, T.encode_sign(int(round(max(-1000.0, min(1000.0, self.load)))), 10))
        self._put(T.PRESENT_VOLTAGE, int(round(self.voltage * 10)))
        self._put(T.PRESENT_TEMPERATURE, int(round(self.temperature)))
        self._put(T.STATUS, self.error_bits())
        self._put(T.MOVING, int(abs(self.velocity) > 1.0))

    # -- physics ---------------------------------------------------------------------------------
    def update(self, t: float | None = None) -> None:
        """Advance the model to time `t` (default: now)."""
        t = self.clock() if t is None else t
        dt, self._t = max(0.0, t - self._t), t
        before = self.encoder
        spinning = self.torque_on and self.reg(T.OPERATING_MODE) == T.VELOCITY_MODE
        if spinning:
            self._spin(dt)
        else:
            self.wheel_speed = 0.0  # torque off (or position mode): a wheel does not keep spinning
        if self.torque_on and not spinning:
            self._track(dt)
        elif self.hand is not None:
            pos = self.hand(t)
            if pos is not None:
                self.encoder = min(max(float(pos), self.stops[0]), self.stops[1])
            self.load = 0.0
        else:
            self.load = 0.0
        self.velocity = self.wheel_speed if spinning else (self.encoder - before) / dt if dt > 0 else 0.0
        self._protect(t)

    def _spin(self, dt: float) -> None:
        """Wheel mode: the speed approaches the goal speed (first order, `tau`); the encoder integrates it
        exactly over `dt`."""
        goal = T.decode_sign(self.reg(T.GOAL_VELOCITY), T.SIGN_BITS[T.GOAL_VELOCITY])
        goal = max(-self.max_speed, min(self.max_speed, float(goal)))
        v0 = self.wheel_speed
        decay = math.exp(-dt / self.tau) if self.tau > 0 else 0.0
        self.wheel_speed = goal + (v0 - goal) * decay
        self.encoder += goal * dt + (v0 - goal) * self.tau * (1.0 - decay)
        cap = min(1000.0, float(self.reg(T.TORQUE_LIMIT)))
        self.load = math.copysign(min(cap, FREE_LOAD_AT_MAX_SPEED * min(abs(self.wheel_speed) / self.max_speed, 1.0)),
                                  self.wheel_speed or 1.0)

    def _track(self, dt: float) -> None:
        lo, hi = self.reg(T.MIN_POSITION_LIMIT), self.reg(T.MAX_POSITION_LIMIT)
        goal = min(max(self.reg(T.GOAL_POSITION), lo), hi)
        limit = self.reg(T.GOAL_VELOCITY) or self.max_speed
        vmax = min(float(limit), self.max_speed)
        p = self.present()
        err = goal - p
        band = vmax * self.tau  # beyond it the speed cap binds
        if abs(err) > band:
            t_sat = (abs(err) - band) / vmax
            if dt <= t_sat:
                new = p + math.copysign(vmax * dt, err)
            else:
                new = goal - math.copysign(band, err) * math.exp(-(dt - t_sat) / self.tau)
        else:
            new = goal - err * math.exp(-dt / self.tau)
        goal_enc = self.encoder + err
        enc = self.encoder + (new - p)
        self.encoder = min(max(enc, self.stops[0]), self.stops[1])
        push = abs(goal_enc - self.encoder) if self.encoder != enc else 0.0
        speed = abs(new - p) / dt if dt > 0 else 0.0
        cap = min(1000.0, float(self.reg(T.TORQUE_LIMIT)))  # the output (and so the load) is capped
        self.load = math.copysign(min(cap, push * BLOCKED_LOAD_PER_STEP
                                      + FREE_LOAD_AT_MAX_SPEED * min(speed / self.max_speed, 1.0)), err)

    def _protect(self, t: float) -> None:
        if not self.torque_on:
            self._overload_since = None
            return
        if abs(self.load) > 10 * self.reg(T.OVERLOAD_TORQUE):
            if self._overload_since is None:
                self._overload_since = t
            elif t - self._overload_since >= 0.01 * self.reg(T.PROTECTION_TIME):
                self.overloaded = True  # latched until torque is enabled again
                self.load = 0.0
        else:
            self._overload_since = None
