"""`ServoGroup`: the calibrated joints one driver owns on a bus, read and written in one packet each.

Every cycle a driver does one SYNC READ of the state block (position, velocity, load, voltage,
temperature, status) for its servos and, if it commands them, one SYNC WRITE of goal positions.
Conversions to SI units go through the calibration; servo error bits (from the status packets and
the STATUS register) are collected here and turned into a `ServoFault` by `check_faults`.
"""

from __future__ import annotations

import numpy as np

from .calibration import RAD_PER_STEP, JointCalibration
from .errors import ServoFault
from .feetech import control_table as T
from .feetech.bus import FeetechBus

_BLOCK_ADDR, _BLOCK_LEN = T.STATE_BLOCK


def read_state_block(bus: FeetechBus, ids: list[int]) -> dict[str, np.ndarray]:
    """One SYNC READ of the state block of servos `ids`, decoded per servo: position (steps), speed (steps/s,
    signed), load (fraction of max torque, signed), voltage (V), temperature (deg C), error bits (the
    status packet's and the servo's own). Arm joints and LeKiwi's wheels read the same block."""
    data, errors = bus.sync_read(ids, _BLOCK_ADDR, _BLOCK_LEN)
    n = len(ids)
    steps, vel, load = np.empty(n), np.empty(n), np.empty(n)
    volt, temp, err = np.empty(n), np.empty(n), np.zeros(n, np.int64)
    for k, sid in enumerate(ids):
        d = data[sid]
        steps[k] = T.from_bytes(d, 0, 2)
        vel[k] = T.decode_sign(T.from_bytes(d, 2, 2), 15)
        load[k] = T.decode_sign(T.from_bytes(d, 4, 2), 10) / 1000.0
        volt[k], temp[k] = d[6] / 10.0, d[7]
        err[k] = int(errors.get(sid, 0)) | int(d[9])
    return {"steps": steps, "vel_steps": vel, "load": load, "voltage": volt, "temperature": temp, "error": err}


class ServoGroup:
    def __init__(self, bus: FeetechBus, joints: dict[str, JointCalibration]):
        self.bus, self.joints = bus, dict(joints)
        self.cal = list(self.joints.values())
        self.ids = [j.id for j in self.cal]
        self.names = list(self.joints)
        self._sign = np.array([j.sign for j in self.cal], dtype=np.float64)
        self._zero = np.array([j.zero for j in self.cal], dtype=np.float64)

    # -- limits ------------------------------------------------------------------------------------
    def limits_rad(self) -> tuple[np.ndarray, np.ndarray]:
        lim = np.array([j.limits_rad() for j in self.cal], dtype=np.float64).reshape(-1, 2)
        return lim[:, 0], lim[:, 1]

    def to_rad(self, steps) -> np.ndarray:
        return self._sign * (np.asarray(steps, dtype=np.float64) - self._zero) * RAD_PER_STEP

    def to_steps(self, rad) -> dict[int, int]:
        return {j.id: j.to_steps(float(q)) for j, q in zip(self.cal, np.asarray(rad).reshape(-1), strict=True)}

    # -- the hot path ------------------------------------------------------------------------------
    def read(self) -> dict[str, np.ndarray]:
        """One SYNC READ -> steps, rad, rad/s, load (fraction of max torque, signed), voltage (V),
        temperature (deg C), error bits per servo."""
        s = read_state_block(self.bus, self.ids)
        return {"steps": s["steps"], "joint_pos": self.to_rad(s["steps"]),
                "joint_vel": self._sign * s["vel_steps"] * RAD_PER_STEP, "load": s["load"], "voltage": s["voltage"],
                "temperature": s["temperature"], "error": s["error"]}

    def faults(self, sample: dict[str, np.ndarray]) -> dict[int, int]:
        return {sid: int(e) for sid, e in zip(self.ids, sample["error"], strict=True) if e}

    def check_faults(self, sample: dict[str, np.ndarray], *, hold: bool) -> None:
        """Raise `ServoFault` naming every faulty servo; first freeze the group where it is (goal =
        present position) when it is under torque, so the arm stops instead of finishing a move."""
        faults = self.faults(sample)
        if not faults:
            return
        if hold:
            try:
                self.write_steps({sid: int(s) for sid, s in zip(self.ids, sample["steps"], strict=True)})
            except Exception:
                pass  # the fault is what the user must see
        names = dict(zip(self.ids, self.names, strict=True))
        raise ServoFault(self.bus.port, faults, names)

    def write_steps(self, goals: dict[int, int]) -> None:
        self.bus.sync_write(T.GOAL_POSITION, goals)

    def write_rad(self, q) -> None:
        self.write_steps(self.to_steps(q))

    # -- setup -------------------------------------------------------------------------------------
    def configure(self, p_gain: int | None = None, i_gain: int | None = None, d_gain: int | None = None,
                  torque_limit: float | None = None) -> None:
        """Position mode, PID gains (EEPROM: unlocked while written) and the output torque limit."""
        for sid in self.ids:
            self.bus.write(sid, T.TORQUE_ENABLE, 0)
            self.bus.write(sid, T.LOCK, 0)
            self.bus.write(sid, T.OPERATING_MODE, 0)
            for reg, value in ((T.P_GAIN, p_gain), (T.I_GAIN, i_gain), (T.D_GAIN, d_gain)):
                if value is not None:
                    self.bus.write(sid, reg, int(value))
            self.bus.write(sid, T.LOCK, 1)
            if torque_limit is not None:
                self.bus.write(sid, T.TORQUE_LIMIT, int(round(1000 * torque_limit)))

    def set_torque(self, on: bool) -> None:
        """Torque on holds the present position (goal = present first, so nothing jumps)."""
        if on:
            sample = self.read()
            self.check_faults(sample, hold=False)
            self.write_steps({sid: int(s) for sid, s in zip(self.ids, sample["steps"], strict=True)})
        for sid in self.ids:
            self.bus.write(sid, T.TORQUE_ENABLE, 1 if on else 0, check_error=on)  # torque off always goes
