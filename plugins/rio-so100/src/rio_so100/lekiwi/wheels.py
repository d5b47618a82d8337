"""`lekiwi.base`: LeKiwi's three omni wheels, STS3215 servos in wheel mode on a Feetech bus.

Hardware logic only; the base kind (`rio.interfaces.BaseNode`) runs the cycle, the safety (speed and
acceleration limits, the stop watchdog) and the odometry. On open the servos are put in wheel mode
(OPERATING_MODE 1: an EEPROM register, written unlocked) with torque off; `set_enabled` switches torque,
always with a zero goal speed first. Each tick is one SYNC READ of the state block (position, speed, load,
voltage, temperature, status: servo error bits stop the base, zero speed first, and end the node naming
the servo) and one SYNC WRITE of the three goal speeds: the body twist through the omni-wheel kinematics
to rad/s, then encoder steps/s, signed as the servo takes them (sign-magnitude, bit 15). A twist that would
turn a wheel faster than `max_wheel_steps` is scaled down as a whole, so the base keeps its heading.

The wheels share LeKiwi's one bus with the arm (ids 1-6): with the same `port` as the follower and gripper,
the port lock serializes their transactions. `port = "emulator"` gives the base a private emulated bus with
servos 7-9 in it (`rio_so100.emulator`, whose servos model wheel mode); `port = "sim"` (`"sim:BASE@WORLD"`)
one whose wheels turn with a running rio-sim world's base (`rio_so100.emulator.sim_base`): the driver
against physics.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.control.omni import OmniKinematics
from rio.interfaces import BaseNode, ServoBus

from ..errors import ServoFault
from ..feetech import control_table as T
from ..servo_group import read_state_block
from . import geometry as G

_VEL_SIGN = T.SIGN_BITS[T.GOAL_VELOCITY]


class LeKiwiBase(BaseNode):
    class Config(ServoBus, BaseNode.Config):
        defaults = {"rate_hz": Field(50.0, le=500)}
        wheel_ids: list[int] = Field(list(G.WHEEL_IDS), min_length=3, max_length=3,
                                     description="servo ids of the left, back and right wheels")
        wheel_radius: float = Field(G.WHEEL_RADIUS, gt=0, description="omni wheel radius (m)")
        base_radius: float = Field(G.BASE_RADIUS, gt=0, description="wheel contact to base center (m)")
        max_wheel_steps: int = Field(G.MAX_WHEEL_STEPS, gt=0, le=32767,
                                     description="fastest wheel speed commanded (encoder steps/s)")

    def default_wheel_names(self) -> list[str]:
        return list(G.WHEELS)

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.kinematics = OmniKinematics.from_degrees(G.PUSH_ANGLES_DEG, c.wheel_radius, c.base_radius)
        self.ids = [int(i) for i in c.wheel_ids]
        n = self.n_wheels
        self.example_data = {**self.example_data, "wheel_steps": np.zeros(n, np.int64), "load": np.zeros(n),
                             "temperature": np.zeros(n), "voltage": np.zeros(n), "error": np.zeros(n, np.int64)}
        self.emulator: Any = None
        self.bus: Any = None

    # -- lifecycle ----------------------------------------------------------------------------------
    def open(self) -> None:
        from ..connection import EMULATED_TIMEOUT_MS, check_present
        from ..feetech.bus import FeetechBus

        c, path = self.config, self.config.port
        if c.port == "emulator":
            from ..emulator import FeetechBusEmulator

            self.emulator = FeetechBusEmulator(ids=self.ids)
            path = self.emulator.port
        elif c.port == "sim" or c.port.startswith("sim:"):
            from ..emulator.sim_base import open_sim_wheel_bus

            self.emulator = open_sim_wheel_bus(c.port, self.ids)
            path = self.emulator.port
        names = dict(zip(self.ids, self.wheel_list, strict=True))
        self.bus = FeetechBus(path, baudrate=c.baudrate, retries=c.retries, names=names,
                              min_timeout_ms=EMULATED_TIMEOUT_MS if self.emulator is not None else 0.0).open()
        check_present(self.bus, names, c.port)
        for sid in self.ids:  # wheel mode is an EEPROM register: torque off, unlock, write, lock
            self.bus.write(sid, T.TORQUE_ENABLE, 0)
            self.bus.write(sid, T.LOCK, 0)
            self.bus.write(sid, T.OPERATING_MODE, T.VELOCITY_MODE)
            self.bus.write(sid, T.LOCK, 1)
            mode = self.bus.read(sid, T.OPERATING_MODE)
            if mode != T.VELOCITY_MODE:
                raise RuntimeError(f"{c.port}: {self.bus.servo_name(sid)} stays in operating mode {mode}, not wheel "
                                   f"mode {T.VELOCITY_MODE}")
        self._last_steps: np.ndarray | None = None
        self._turns = np.zeros(self.n_wheels)

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None
        if self.emulator is not None:
            self.emulator.close()
            self.emulator = None

    def set_enabled(self, enabled: bool) -> None:
        self.write_steps(np.zeros(self.n_wheels, np.int64))  # never start (or let go) at an old speed
        for sid in self.ids:
            self.bus.write(sid, T.TORQUE_ENABLE, 1 if enabled else 0, check_error=enabled)

    # -- the hot path -------------------------------------------------------------------------------
    def read_wheels(self) -> dict[str, Any]:
        s = read_state_block(self.bus, self.ids)
        n, steps, vel, err = self.n_wheels, s["steps"], s["vel_steps"], s["error"]
        load, temp, volt = s["load"], s["temperature"], s["voltage"]
        if err.any():
            if self.enabled:
                try:
                    self.write_steps(np.zeros(n, np.int64))  # stop before the fault ends the node
                except Exception:
                    pass  # the fault is what the user must see
            raise ServoFault(self.bus.port, {sid: int(e) for sid, e in zip(self.ids, err, strict=True) if e},
                             dict(zip(self.ids, self.wheel_list, strict=True)))
        self._unwrap(steps)
        return {"wheel_pos": (self._turns * 4096 + steps) / G.STEPS_PER_RAD, "wheel_vel": vel / G.STEPS_PER_RAD,
                "wheel_steps": steps.astype(np.int64), "load": load, "temperature": temp, "voltage": volt,
                "error": err}

    def _unwrap(self, steps: np.ndarray) -> None:
        """Count whole turns: the position register wraps every 4096 steps, a wheel turns endlessly (at
        3000 steps/s and 50 Hz it moves 60 steps a cycle, far from the half turn that would be ambiguous)."""
        if self._last_steps is not None:
            jump = steps - self._last_steps
            self._turns -= np.round(jump / 4096.0)
        self._last_steps = steps.copy()

    def write_twist(self, twist: np.ndarray) -> None:
        self.write_steps(self.wheel_steps(twist))

    def wheel_steps(self, twist: np.ndarray) -> np.ndarray:
        """The goal speed of each wheel (steps/s) for a body twist, scaled down as a whole so no wheel is
        asked for more than `max_wheel_steps`."""
        steps = self.kinematics.to_wheels(twist) * G.STEPS_PER_RAD
        fastest = float(np.abs(steps).max())
        if fastest > self.config.max_wheel_steps:
            steps *= self.config.max_wheel_steps / fastest
        return np.round(steps).astype(np.int64)

    def write_steps(self, steps: np.ndarray) -> None:
        self.bus.sync_write(T.GOAL_VELOCITY, {sid: int(v) for sid, v in zip(self.ids, steps, strict=True)})

    def body_twist_of(self, wheel_vel: np.ndarray) -> np.ndarray:
        return self.kinematics.to_body(wheel_vel)
