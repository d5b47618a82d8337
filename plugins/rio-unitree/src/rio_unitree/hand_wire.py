"""The Dex3-1's two messages (unitree_hg `HandCmd_`, `HandState_`) as bytes, as `wire` does for the body.

Both hold sequences (of `MotorCmd_`, of `MotorState_` and `PressSensorState_`), so their size depends on
the counts, but every element is a fixed record of 4-byte-aligned numbers: in XCDR1 (what cyclonedds
writes for these final types, header 00 01) a sequence is its uint32 length and then the records back
to back, each motor's `mode` byte padded to 4. numpy views read and write them; `tests/test_wire.py`
checks the bytes against cyclonedds' own serializer both ways. Any other encapsulation (e.g. XCDR2 from
another DDS) is decoded by cyclonedds itself. These messages carry no CRC.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .dex3 import NUM_MOTORS
from .wire import HEADER, MOTOR_CMD, MOTOR_STATE, MotorStates, motor_state

_PRESS_REC = np.dtype({"names": ["pressure", "temperature", "lost", "reserve"],
                       "formats": [("<f4", 12), ("<f4", 12), "<u4", "<u4"],
                       "offsets": [0, 48, 96, 100], "itemsize": 104})
_XCDR1 = b"\x00\x01"


def _f32(n: int = NUM_MOTORS) -> np.ndarray:
    return np.zeros(n, np.float32)


@dataclass
class HandCmd:
    """One `rt/dex3/<side>/cmd`: per-motor arrays (7 for a Dex3-1)."""

    mode: np.ndarray = field(default_factory=lambda: np.zeros(NUM_MOTORS, np.uint8))
    q: np.ndarray = field(default_factory=_f32)
    dq: np.ndarray = field(default_factory=_f32)
    tau: np.ndarray = field(default_factory=_f32)
    kp: np.ndarray = field(default_factory=_f32)
    kd: np.ndarray = field(default_factory=_f32)
    reserve: np.ndarray = field(default_factory=lambda: np.zeros(NUM_MOTORS, np.uint32))
    tail: np.ndarray = field(default_factory=lambda: np.zeros(4, np.uint32))

    _FIELDS = tuple(MOTOR_CMD.names or ())

    def encode(self) -> bytes:
        n = len(self.q)
        buf = np.zeros(4 + 28 * n + 16, np.uint8)
        buf[0:4].view("<u4")[0] = n
        rec = buf[4:4 + 28 * n].view(MOTOR_CMD)
        for name in self._FIELDS:
            rec[name] = getattr(self, name)
        buf[4 + 28 * n:].view("<u4")[:] = self.tail
        return HEADER + buf.tobytes()

    @classmethod
    def decode(cls, data: bytes) -> HandCmd:
        if data[:2] != _XCDR1:
            return cls._from_sample(_sdk_decode(data, "HandCmd_"))
        buf = np.frombuffer(data, np.uint8, offset=4)
        n = _count(buf, 0, 28, 16, "HandCmd_")
        rec = buf[4:4 + 28 * n].view(MOTOR_CMD)
        return cls(*(rec[name].copy() for name in cls._FIELDS), buf[4 + 28 * n:4 + 28 * n + 16].view("<u4").copy())

    @classmethod
    def _from_sample(cls, s) -> HandCmd:
        m = s.motor_cmd
        return cls(np.array([x.mode for x in m], np.uint8), *(np.array([getattr(x, f) for x in m], np.float32)
                                                              for f in ("q", "dq", "tau", "kp", "kd")),
                   np.array([x.reserve for x in m], np.uint32), np.array(s.reserve, np.uint32))


@dataclass
class HandState(MotorStates):
    """One `rt/dex3/<side>/state`. `press_*`: one row per pressure sensor pad (12 values each); the IMU
    quaternion is [w, x, y, z]."""

    mode: np.ndarray = motor_state("mode", NUM_MOTORS)
    q: np.ndarray = motor_state("q", NUM_MOTORS)
    dq: np.ndarray = motor_state("dq", NUM_MOTORS)
    ddq: np.ndarray = motor_state("ddq", NUM_MOTORS)
    tau_est: np.ndarray = motor_state("tau_est", NUM_MOTORS)
    temperature: np.ndarray = motor_state("temperature", NUM_MOTORS)
    vol: np.ndarray = motor_state("vol", NUM_MOTORS)
    sensor: np.ndarray = motor_state("sensor", NUM_MOTORS)
    motorstate: np.ndarray = motor_state("motorstate", NUM_MOTORS)
    reserve: np.ndarray = motor_state("reserve", NUM_MOTORS)
    press_pressure: np.ndarray = field(default_factory=lambda: np.zeros((NUM_MOTORS, 12), np.float32))
    press_temperature: np.ndarray = field(default_factory=lambda: np.zeros((NUM_MOTORS, 12), np.float32))
    press_lost: np.ndarray = field(default_factory=lambda: np.zeros(NUM_MOTORS, np.uint32))
    press_reserve: np.ndarray = field(default_factory=lambda: np.zeros(NUM_MOTORS, np.uint32))
    imu: np.ndarray = field(default_factory=lambda: np.array([1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0], np.float32))
    imu_temperature: int = 0
    power: np.ndarray = field(default_factory=lambda: np.zeros(4, np.float32))  # power_v, power_a, system_v, device_v
    error: np.ndarray = field(default_factory=lambda: np.zeros(2, np.uint32))
    tail: np.ndarray = field(default_factory=lambda: np.zeros(2, np.uint32))

    _PRESS = ("pressure", "temperature", "lost", "reserve")

    def encode(self) -> bytes:
        n, m = len(self.q), len(self.press_lost)
        p0 = 4 + 56 * n  # the pressure sensors' length
        i0 = p0 + 4 + 104 * m  # the IMU
        buf = np.zeros(i0 + 52 + 4 + 16 + 16, np.uint8)
        buf[0:4].view("<u4")[0] = n
        self.put_motor_states(buf[4:p0].view(MOTOR_STATE))
        buf[p0:p0 + 4].view("<u4")[0] = m
        press = buf[p0 + 4:i0].view(_PRESS_REC)
        for name in self._PRESS:
            press[name] = getattr(self, f"press_{name}")
        buf[i0:i0 + 52].view("<f4")[:] = self.imu
        buf[i0 + 52:i0 + 54].view("<i2")[0] = self.imu_temperature
        tail = buf[i0 + 56:]
        tail[0:16].view("<f4")[:] = self.power
        tail[16:24].view("<u4")[:] = self.error
        tail[24:32].view("<u4")[:] = self.tail
        return HEADER + buf.tobytes()

    @classmethod
    def decode(cls, data: bytes) -> HandState:
        if data[:2] != _XCDR1:
            return cls._from_sample(_sdk_decode(data, "HandState_"))
        buf = np.frombuffer(data, np.uint8, offset=4)
        n = _count(buf, 0, 56, 4 + 52 + 4 + 32, "HandState_")
        p0 = 4 + 56 * n
        m = _count(buf, p0, 104, 52 + 4 + 32, "HandState_")
        i0 = p0 + 4 + 104 * m
        press = buf[p0 + 4:i0].view(_PRESS_REC)
        tail = buf[i0 + 56:i0 + 88]
        return cls(*cls.motor_states_of(buf[4:p0].view(MOTOR_STATE)), *(press[name].copy() for name in cls._PRESS),
                   buf[i0:i0 + 52].view("<f4").copy(), int(buf[i0 + 52:i0 + 54].view("<i2")[0]),
                   tail[0:16].view("<f4").copy(), tail[16:24].view("<u4").copy(), tail[24:32].view("<u4").copy())

    @classmethod
    def _from_sample(cls, s) -> HandState:
        ms, ps, imu = s.motor_state, s.press_sensor_state, s.imu_state

        def col(items, name, dtype):
            return np.array([getattr(x, name) for x in items], dtype)

        return cls(*cls.motor_states_of_sdk(ms), col(ps, "pressure", np.float32).reshape(-1, 12),
                   col(ps, "temperature", np.float32).reshape(-1, 12), col(ps, "lost", np.uint32),
                   col(ps, "reserve", np.uint32),
                   np.array([*imu.quaternion, *imu.gyroscope, *imu.accelerometer, *imu.rpy], np.float32),
                   int(imu.temperature), np.array([s.power_v, s.power_a, s.system_v, s.device_v], np.float32),
                   np.array(s.error, np.uint32), np.array(s.reserve, np.uint32))


def _count(buf: np.ndarray, at: int, record: int, after: int, what: str) -> int:
    if len(buf) < at + 4:
        raise ValueError(f"a {what} of {len(buf) + 4} bytes is too short")
    n = int(buf[at:at + 4].view("<u4")[0])
    if len(buf) < at + 4 + record * n + after:
        raise ValueError(f"a {what} of {len(buf) + 4} bytes cannot hold its {n} records")
    return n


def _sdk_decode(data: bytes, type_name: str):
    from unitree_sdk2py.idl.unitree_hg.msg import dds_

    return getattr(dds_, type_name).deserialize(data)
