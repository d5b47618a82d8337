"""The G1's two low-level messages (unitree_hg `LowCmd_`, `LowState_`) as bytes, and their CRC.

Why not the SDK's message classes: cyclonedds' Python serializer takes ~0.3 ms for a LowCmd_ and
~0.55 ms for a LowState_, and the SDK's `CRC().Crc()` another ~0.3-0.5 ms, so a 500 Hz loop would
spend most of a core in Python before doing anything. Both messages are fixed-size ("final" structs
of numbers), so their CDR payload is a fixed byte layout: numpy views read and write it in
microseconds. `tests/test_wire.py` checks the bytes against cyclonedds' own serializer and the CRC
against the SDK's `CRC().Crc()` on random messages, both ways.

The CRC the robot checks is CRC-32/MPEG-2 over the message's C struct (as `unitree_sdk2py.utils.crc`
packs it: little-endian, C padding, every 32-bit word but the last, which holds the CRC). The C layout
differs from CDR's only around the first motor's `mode` byte (CDR packs it right after the bytes
before it; C gives each motor a 4-byte-aligned record), so the C image is a few slice copies away.
"""

from __future__ import annotations

import ctypes
import functools
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .g1 import NUM_SLOTS

_LE_HEADERS = (b"\x00\x01", b"\x00\x07")  # CDR_LE (XCDR1), PLAIN_CDR2_LE: same payload for final structs
HEADER = b"\x00\x01\x00\x00"

#: One unitree_hg `MotorCmd_` in CDR, as `LowCmd_` (the body) and `HandCmd_` (a Dex3-1) carry one per motor.
MOTOR_CMD = np.dtype({"names": ["mode", "q", "dq", "tau", "kp", "kd", "reserve"],
                      "formats": ["u1", "<f4", "<f4", "<f4", "<f4", "<f4", "<u4"],
                      "offsets": [0, 4, 8, 12, 16, 20, 24], "itemsize": 28})
#: One unitree_hg `MotorState_` in CDR, as `LowState_` and `HandState_` carry one per motor.
MOTOR_STATE = np.dtype({"names": ["mode", "q", "dq", "ddq", "tau_est", "temperature", "vol", "sensor", "motorstate",
                                  "reserve"],
                        "formats": ["u1", "<f4", "<f4", "<f4", "<f4", ("<i2", 2), "<f4", ("<u4", 2), "<u4", ("<u4", 4)],
                        "offsets": [0, 4, 8, 12, 16, 20, 24, 28, 36, 40], "itemsize": 56})

CMD_SIZE = 1000  # CDR payload bytes after the 4-byte header
STATE_SIZE = 2088
_CMD_MOTORS = slice(0, 28 * NUM_SLOTS)  # motor k's record at 28k; motor 0's mode byte sits at 2
_STATE_MOTORS = slice(68, 68 + 56 * NUM_SLOTS)  # motor k's record at 68 + 56k; motor 0's mode at 70


def _f32() -> np.ndarray:
    return np.zeros(NUM_SLOTS, np.float32)


def motor_state(name: str, n: int) -> Any:
    """The dataclass field of `MOTOR_STATE`'s `name` for `n` motors (zeros of its dtype and shape)."""
    kind = MOTOR_STATE.fields[name][0]
    return field(default_factory=lambda: np.zeros((n, *kind.shape), kind.base))


class MotorStates:
    """The per-motor block of a message of `MotorState_` records (`LowState`, the Dex3-1's `HandState`):
    one array field per `MOTOR_STATE` field, each declared with `motor_state(name, n)`, and the one place
    they are read from and written to records."""

    MOTOR_FIELDS: tuple[str, ...] = tuple(MOTOR_STATE.names or ())

    def put_motor_states(self, rec: np.ndarray) -> None:
        for name in self.MOTOR_FIELDS:
            rec[name] = getattr(self, name)

    @classmethod
    def motor_states_of(cls, rec: np.ndarray) -> list[np.ndarray]:
        """The arrays, in field order, out of `MOTOR_STATE` records."""
        return [rec[name].copy() for name in cls.MOTOR_FIELDS]

    @classmethod
    def motor_states_of_sdk(cls, motors: Iterable[Any]) -> list[np.ndarray]:
        """The arrays, in field order, out of the SDK's `MotorState_` objects."""
        motors = list(motors)
        return [np.array([getattr(m, name) for m in motors], MOTOR_STATE.fields[name][0].base)
                for name in cls.MOTOR_FIELDS]


@dataclass
class LowCmd:
    """One `rt/lowcmd` (or `rt/arm_sdk`) message: per-slot arrays of the 35 motor commands."""

    mode_pr: int = 0
    mode_machine: int = 0
    mode: np.ndarray = field(default_factory=lambda: np.zeros(NUM_SLOTS, np.uint8))
    q: np.ndarray = field(default_factory=_f32)
    dq: np.ndarray = field(default_factory=_f32)
    tau: np.ndarray = field(default_factory=_f32)
    kp: np.ndarray = field(default_factory=_f32)
    kd: np.ndarray = field(default_factory=_f32)
    reserve: np.ndarray = field(default_factory=lambda: np.zeros(NUM_SLOTS, np.uint32))
    tail: np.ndarray = field(default_factory=lambda: np.zeros(4, np.uint32))
    crc: int = 0

    def payload(self) -> np.ndarray:
        """The CDR payload (no header), with `crc` as it is."""
        buf = np.zeros(CMD_SIZE, np.uint8)
        rec = buf[_CMD_MOTORS].view(MOTOR_CMD)
        for name in ("q", "dq", "tau", "kp", "kd", "reserve"):
            rec[name] = getattr(self, name)
        rec["mode"][1:] = self.mode[1:]
        buf[0], buf[1], buf[2] = self.mode_pr, self.mode_machine, self.mode[0]  # over record 0's first bytes
        buf[980:996].view("<u4")[:] = self.tail
        buf[996:1000].view("<u4")[0] = self.crc
        return buf

    def encode(self, fix_crc: bool = True) -> bytes:
        """Bytes for the wire, with the CRC the robot checks (unless `fix_crc` is false)."""
        buf = self.payload()
        if fix_crc:
            self.crc = cmd_crc(buf)
            buf[996:1000].view("<u4")[0] = self.crc
        return HEADER + buf.tobytes()

    @classmethod
    def decode(cls, data: bytes) -> LowCmd:
        buf = _payload(data, CMD_SIZE, "LowCmd_")
        rec = buf[_CMD_MOTORS].view(MOTOR_CMD)
        mode = rec["mode"].copy()
        mode[0] = buf[2]
        return cls(int(buf[0]), int(buf[1]), mode, *(rec[n].copy() for n in ("q", "dq", "tau", "kp", "kd", "reserve")),
                   buf[980:996].view("<u4").copy(), int(buf[996:1000].view("<u4")[0]))


@dataclass
class LowState(MotorStates):
    """One `rt/lowstate` message. The IMU quaternion is [w, x, y, z]; gyroscope in rad/s, body frame."""

    version: np.ndarray = field(default_factory=lambda: np.zeros(2, np.uint32))
    mode_pr: int = 0
    mode_machine: int = 0
    tick: int = 0
    quaternion: np.ndarray = field(default_factory=lambda: np.array([1, 0, 0, 0], np.float32))
    gyroscope: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))
    accelerometer: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))
    rpy: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))
    imu_temperature: int = 0
    mode: np.ndarray = motor_state("mode", NUM_SLOTS)
    q: np.ndarray = motor_state("q", NUM_SLOTS)
    dq: np.ndarray = motor_state("dq", NUM_SLOTS)
    ddq: np.ndarray = motor_state("ddq", NUM_SLOTS)
    tau_est: np.ndarray = motor_state("tau_est", NUM_SLOTS)
    temperature: np.ndarray = motor_state("temperature", NUM_SLOTS)
    vol: np.ndarray = motor_state("vol", NUM_SLOTS)
    sensor: np.ndarray = motor_state("sensor", NUM_SLOTS)
    motorstate: np.ndarray = motor_state("motorstate", NUM_SLOTS)
    reserve: np.ndarray = motor_state("reserve", NUM_SLOTS)
    wireless_remote: np.ndarray = field(default_factory=lambda: np.zeros(40, np.uint8))
    tail: np.ndarray = field(default_factory=lambda: np.zeros(4, np.uint32))
    crc: int = 0

    def payload(self) -> np.ndarray:
        buf = np.zeros(STATE_SIZE, np.uint8)
        self.put_motor_states(buf[_STATE_MOTORS].view(MOTOR_STATE))  # motor 0's mode byte is moved below
        buf[0:8].view("<u4")[:] = self.version
        buf[8], buf[9] = self.mode_pr, self.mode_machine
        buf[12:16].view("<u4")[0] = self.tick
        buf[16:68].view("<f4")[:] = np.concatenate([self.quaternion, self.gyroscope, self.accelerometer, self.rpy])
        buf[68:70].view("<i2")[0] = self.imu_temperature  # over record 0's first bytes
        buf[70] = self.mode[0]
        buf[2028:2068] = self.wireless_remote
        buf[2068:2084].view("<u4")[:] = self.tail
        buf[2084:2088].view("<u4")[0] = self.crc
        return buf

    def encode(self, fix_crc: bool = True) -> bytes:
        buf = self.payload()
        if fix_crc:
            self.crc = state_crc(buf)
            buf[2084:2088].view("<u4")[0] = self.crc
        return HEADER + buf.tobytes()

    @classmethod
    def decode(cls, data: bytes) -> LowState:
        buf = _payload(data, STATE_SIZE, "LowState_")
        motors = cls.motor_states_of(buf[_STATE_MOTORS].view(MOTOR_STATE))
        motors[0][0] = buf[70]  # motor 0's mode byte, after the IMU's temperature
        imu = buf[16:68].view("<f4").astype(np.float32)
        return cls(buf[0:8].view("<u4").copy(), int(buf[8]), int(buf[9]), int(buf[12:16].view("<u4")[0]),
                   imu[0:4], imu[4:7], imu[7:10], imu[10:13], int(buf[68:70].view("<i2")[0]), *motors,
                   buf[2028:2068].copy(),
                   buf[2068:2084].view("<u4").copy(), int(buf[2084:2088].view("<u4")[0]))


def _payload(data: bytes, size: int, what: str) -> np.ndarray:
    if len(data) < 4 + size:
        raise ValueError(f"a {what} is {4 + size} bytes with its header, got {len(data)}")
    if data[:2] not in _LE_HEADERS:
        raise ValueError(f"{what}: unsupported CDR encapsulation {data[:2].hex()} (little-endian CDR expected)")
    return np.frombuffer(data, np.uint8, size, 4)


# -- CRC ----------------------------------------------------------------------------------------------
def cmd_crc(payload: np.ndarray) -> int:
    """The CRC of a LowCmd_ from its CDR payload (the C struct rebuilt around motor 0's mode byte)."""
    c = np.zeros(CMD_SIZE, np.uint8)  # the C struct without its CRC word
    c[0:2] = payload[0:2]
    c[4:984] = payload[0:980]
    c[4], c[5:8] = payload[2], 0
    c[984:1000] = payload[980:996]
    return crc32_words(c.view("<u4"))


def state_crc(payload: np.ndarray) -> int:
    """The CRC of a LowState_ from its CDR payload."""
    c = np.zeros(STATE_SIZE, np.uint8)
    c[0:70] = payload[0:70]
    c[72:2032] = payload[68:2028]
    c[72], c[73:76] = payload[70], 0
    c[2032:2088] = payload[2028:2084]
    return crc32_words(c.view("<u4"))


def cmd_crc_ok(data: bytes) -> bool:
    buf = _payload(data, CMD_SIZE, "LowCmd_")
    return int(buf[996:1000].view("<u4")[0]) == cmd_crc(buf)


def state_crc_ok(data: bytes) -> bool:
    return state_signature(data) == "signed"


def state_signature(data: bytes) -> str:
    """How a LowState_ is signed: "signed" (its CRC is right), "unsigned" (its CRC field is 0, as Unitree's
    unitree_mujoco publishes it) or "wrong" (a CRC that does not match: damaged, or not a G1's)."""
    buf = _payload(data, STATE_SIZE, "LowState_")
    crc = int(buf[2084:2088].view("<u4")[0])
    if crc == state_crc(buf):
        return "signed"
    return "unsigned" if crc == 0 else "wrong"


@functools.cache
def _sdk_crc_core():
    """The SDK's compiled CRC routine (Linux x86_64 / aarch64), or None elsewhere."""
    try:
        from unitree_sdk2py.utils.crc import CRC
    except ImportError:
        return None
    lib = getattr(CRC(), "crc_lib", None)
    return None if lib is None else lib.crc32_core


@functools.cache
def _table() -> np.ndarray:
    t = np.zeros(256, np.uint32)
    for i in range(256):
        c = i << 24
        for _ in range(8):
            c = ((c << 1) ^ 0x04C11DB7) if c & 0x80000000 else (c << 1)
        t[i] = c & 0xFFFFFFFF
    return t


def crc32_words(words: np.ndarray) -> int:
    """Unitree's CRC over 32-bit words (each word's bits from the most significant): CRC-32/MPEG-2 of
    the words written big-endian. The SDK's C routine when it has one, else a table in Python."""
    words = np.ascontiguousarray(words, dtype=np.uint32)
    core = _sdk_crc_core()
    if core is not None:
        return int(core(words.ctypes.data_as(ctypes.POINTER(ctypes.c_uint32)), words.size))
    crc, table = 0xFFFFFFFF, _table()
    for b in words.astype(">u4").tobytes():
        crc = ((crc << 8) & 0xFFFFFFFF) ^ int(table[(crc >> 24) ^ b])
    return crc
