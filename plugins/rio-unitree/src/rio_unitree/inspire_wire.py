"""The Inspire hands' two messages (unitree_go `MotorCmds_`, `MotorStates_`) as bytes, as `hand_wire` does
for the Dex3-1.

Unlike the unitree_hg records of the body and the Dex3-1, these are the unitree_go (Go2) motor records:
`MotorCmd_` is mode, q, dq, tau, kp, kd and three reserve words (36 bytes in CDR); `MotorState_` is mode,
q, dq, ddq, tau_est, q_raw, dq_raw, ddq_raw, a uint8 temperature, lost and two reserve words (48 bytes).
Each message is one sequence of them and nothing else: in XCDR1 (header 00 01) the uint32 count, then the
records back to back. `tests/test_inspire.py` checks the bytes against cyclonedds' own serializer of the
SDK's IDL both ways; another encapsulation (e.g. XCDR2 from another DDS) is decoded by cyclonedds itself.
No CRC.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .wire import HEADER

#: One unitree_go `MotorCmd_` in CDR.
GO_MOTOR_CMD = np.dtype({"names": ["mode", "q", "dq", "tau", "kp", "kd", "reserve"],
                         "formats": ["u1", "<f4", "<f4", "<f4", "<f4", "<f4", ("<u4", 3)],
                         "offsets": [0, 4, 8, 12, 16, 20, 24], "itemsize": 36})
#: One unitree_go `MotorState_` in CDR.
GO_MOTOR_STATE = np.dtype({"names": ["mode", "q", "dq", "ddq", "tau_est", "q_raw", "dq_raw", "ddq_raw", "temperature",
                                     "lost", "reserve"],
                           "formats": ["u1", "<f4", "<f4", "<f4", "<f4", "<f4", "<f4", "<f4", "u1", "<u4", ("<u4", 2)],
                           "offsets": [0, 4, 8, 12, 16, 20, 24, 28, 32, 36, 40], "itemsize": 48})
_XCDR1 = b"\x00\x01"


def _kind(dtype: np.dtype, name: str) -> np.dtype:
    """The dtype (with its shape) of one record field."""
    assert dtype.fields is not None
    return dtype.fields[name][0]


class _Records:
    """A message that is one sequence of fixed records (`DTYPE`): one array field per record field."""

    DTYPE: np.dtype
    SDK_TYPE: str
    SDK_FIELD: str

    @classmethod
    def zeros(cls, n: int) -> Any:
        kinds = [_kind(cls.DTYPE, name) for name in cls.DTYPE.names or ()]
        return cls(*(np.zeros((n, *k.shape), k.base) for k in kinds))

    def encode(self) -> bytes:
        names = self.DTYPE.names or ()
        n = len(getattr(self, names[0]))
        buf = np.zeros(4 + self.DTYPE.itemsize * n, np.uint8)
        buf[0:4].view("<u4")[0] = n
        rec = buf[4:].view(self.DTYPE)
        for name in names:
            rec[name] = getattr(self, name)
        return HEADER + buf.tobytes()

    @classmethod
    def decode(cls, data: bytes) -> Any:
        if data[:2] != _XCDR1:
            return cls.from_sample(_sdk_decode(data, cls.SDK_TYPE))
        buf = np.frombuffer(data, np.uint8, offset=4)
        if len(buf) < 4:
            raise ValueError(f"a {cls.SDK_TYPE} of {len(data)} bytes is too short")
        n = int(buf[0:4].view("<u4")[0])
        size = cls.DTYPE.itemsize
        if len(buf) < 4 + size * n:
            raise ValueError(f"a {cls.SDK_TYPE} of {len(data)} bytes cannot hold its {n} records")
        rec = buf[4:4 + size * n].view(cls.DTYPE)
        return cls(*(rec[name].copy() for name in cls.DTYPE.names or ()))

    @classmethod
    def from_sample(cls, sample: Any) -> Any:
        """From the SDK's message object."""
        items = list(getattr(sample, cls.SDK_FIELD))
        kinds = [(name, _kind(cls.DTYPE, name)) for name in cls.DTYPE.names or ()]
        return cls(*(np.array([getattr(x, name) for x in items], k.base).reshape(len(items), *k.shape)
                     for name, k in kinds))


@dataclass
class MotorCmds(_Records):
    """One `rt/inspire/cmd`: per-motor arrays (12 for the G1's two Inspire hands)."""

    mode: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    q: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    dq: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    tau: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    kp: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    kd: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    reserve: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.uint32))

    DTYPE = GO_MOTOR_CMD
    SDK_TYPE, SDK_FIELD = "MotorCmds_", "cmds"


@dataclass
class MotorStates(_Records):
    """One `rt/inspire/state`: per-motor arrays (12)."""

    mode: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    q: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    dq: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    ddq: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    tau_est: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    q_raw: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    dq_raw: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    ddq_raw: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    temperature: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    lost: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint32))
    reserve: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.uint32))

    DTYPE = GO_MOTOR_STATE
    SDK_TYPE, SDK_FIELD = "MotorStates_", "states"


def _sdk_decode(data: bytes, type_name: str) -> Any:
    from unitree_sdk2py.idl.unitree_go.msg import dds_

    return getattr(dds_, type_name).deserialize(data)
