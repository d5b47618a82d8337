"""The calibration procedure, apart from any terminal I/O (the `rio so100 calibrate` command and the
tests drive the same steps):

1. `prepare()`: torque off (the user moves the arm by hand), homing offsets and position limits
   reset, so raw encoder positions are read;
2. `record_middle()`: with the arm in the middle of every joint's range, set each homing offset so
   that pose reads mid-turn (2048) and becomes 0 rad;
3. `sample()`, repeatedly, while the user moves every joint through its whole range: the extremes
   seen so far;
4. `finish()`: check that every joint moved, write the ranges as the servos' position limits and
   return the `ArmCalibration` (the caller saves it).
"""

from __future__ import annotations

import numpy as np

from .calibration import MID, ArmCalibration, JointCalibration
from .errors import CalibrationError
from .feetech import control_table as T
from .feetech.bus import FeetechBus

#: A joint whose recorded range is smaller than this (steps, ~9 degrees) was not moved.
MIN_RANGE_STEPS = 100
_MAX_OFFSET = 2047  # sign-magnitude with 11 bits of magnitude


class Calibrator:
    def __init__(self, bus: FeetechBus, joints: dict[str, int]):
        self.bus, self.joints = bus, dict(joints)
        self.ids = list(self.joints.values())
        self.offsets: dict[str, int] = {}
        self.zero: dict[str, int] = {}
        self.lo: dict[str, int] = {}
        self.hi: dict[str, int] = {}

    def _present(self) -> dict[str, int]:
        data, _ = self.bus.sync_read(self.ids, T.PRESENT_POSITION[0], 2)
        return {name: T.from_bytes(data[sid], 0, 2) for name, sid in self.joints.items()}

    def prepare(self) -> None:
        for sid in self.ids:
            self.bus.write(sid, T.TORQUE_ENABLE, 0, check_error=False)
            self.bus.write(sid, T.LOCK, 0)
            self.bus.write(sid, T.HOMING_OFFSET, 0)
            self.bus.write(sid, T.MIN_POSITION_LIMIT, 0)
            self.bus.write(sid, T.MAX_POSITION_LIMIT, T.STEPS_PER_TURN - 1)
            self.bus.write(sid, T.LOCK, 1)

    def record_middle(self) -> dict[str, int]:
        """Homing offsets that make the present pose read mid-turn; written to the servos."""
        raw = self._present()
        for name, sid in self.joints.items():
            off = int(np.clip(raw[name] - MID, -_MAX_OFFSET, _MAX_OFFSET))
            self.bus.write(sid, T.LOCK, 0)
            self.bus.write(sid, T.HOMING_OFFSET, off)
            self.bus.write(sid, T.LOCK, 1)
            self.offsets[name] = off
        self.zero = self._present()  # == MID unless the offset was clipped
        self.lo, self.hi = dict(self.zero), dict(self.zero)
        return dict(self.offsets)

    def sample(self) -> dict[str, tuple[int, int, int]]:
        """Read once; returns {joint: (min, now, max)} seen so far."""
        now = self._present()
        for name, v in now.items():
            self.lo[name], self.hi[name] = min(self.lo[name], v), max(self.hi[name], v)
        return {name: (self.lo[name], now[name], self.hi[name]) for name in self.joints}

    def finish(self, model: str, device: str, name: str) -> ArmCalibration:
        if not self.zero:
            raise CalibrationError("record the middle position before finishing")
        still = [j for j in self.joints if self.hi[j] - self.lo[j] < MIN_RANGE_STEPS]
        if still:
            raise CalibrationError(f"joint(s) {', '.join(still)} barely moved: move every joint through its whole "
                                   "range of motion, then finish")
        joints = {j: JointCalibration(sid, self.offsets[j], self.zero[j], self.lo[j], self.hi[j], 1)
                  for j, sid in self.joints.items()}
        for jc in joints.values():
            self.bus.write(jc.id, T.LOCK, 0)
            self.bus.write(jc.id, T.MIN_POSITION_LIMIT, jc.range_min)
            self.bus.write(jc.id, T.MAX_POSITION_LIMIT, jc.range_max)
            self.bus.write(jc.id, T.LOCK, 1)
        return ArmCalibration(model, device, name, joints)
