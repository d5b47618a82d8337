"""The controller's report frames, encoded from a `machine.Snapshot`.

Every frame starts with its total length (u32 BE); a client reads that once and then expects frames
of exactly that size, so each port always sends the same layout. Floats are little-endian fp32.

- real-time (30003, 135 bytes): state | mode << 4, command count, 7 joint angles, TCP pose (mm, rad),
  7 joint torques, then the force/torque sensor (external and raw, 6 each);
- normal (30001, 145 bytes): the first 87 bytes as above, then motor brake and enable bits, error and
  warning codes, TCP offset, TCP load (mass and centre of mass), collision and teach sensitivity,
  gravity direction;
- rich (30002, 587 bytes): normal, then the arm's identity (device type, axis count, ...), version,
  motion limits, servo codes, temperatures, speeds, a counter, world offset, GPIO and safety settings,
  force/torque, axis-angle orientation, reduced mode and the joint ranges.
"""

from __future__ import annotations

import struct

import numpy as np

from .machine import Snapshot
from .protocol import pack_floats

REAL_SIZE = 135
NORMAL_SIZE = 145
RICH_SIZE = 587


def _head(s: Snapshot, size: int) -> bytes:
    return (struct.pack(">IBH", size, (s.state & 0x0F) | ((s.mode & 0x0F) << 4), s.cmdnum & 0xFFFF)
            + pack_floats(s.q) + pack_floats(s.pose) + pack_floats(s.torque))


def encode_real(s: Snapshot) -> bytes:
    out = _head(s, REAL_SIZE) + pack_floats(np.zeros(12))
    assert len(out) == REAL_SIZE
    return out


def _normal_body(s: Snapshot) -> bytes:
    return (bytes([s.mtbrake & 0xFF, s.mtable & 0xFF, s.error & 0xFF, s.warn & 0xFF])
            + pack_floats(s.tcp_offset) + pack_floats(s.tcp_load)
            + bytes([s.collision_sens & 0xFF, s.teach_sens & 0xFF]) + pack_floats(s.gravity))


def encode_normal(s: Snapshot) -> bytes:
    out = _head(s, NORMAL_SIZE) + _normal_body(s)
    assert len(out) == NORMAL_SIZE
    return out


def encode_rich(s: Snapshot) -> bytes:
    b = bytearray(_head(s, RICH_SIZE) + _normal_body(s))  # 145
    b += bytes([s.device_type, s.axis, 0, 0, 0, 0])  # type, axis, master/slave id, motor tid/fid
    b += s.version.encode("ascii")[:29].ljust(30, b"\0")  # 151..181
    b += pack_floats([10000.0, 1.0, 50000.0, 0.1, 1000.0])  # TCP jerk, min/max acc, min/max speed
    b += pack_floats([500.0, 0.01, 20.0, 0.0001, 4.0])  # joint jerk, min/max acc, min/max speed
    b += pack_floats([2.3, 2.7])  # rotation jerk, max rotation acceleration
    b += s.servo_codes[:14].ljust(14, b"\0") + bytes(2)  # servo (status, code) x7, tool GPIO codes
    b += bytes([30] * 7)  # joint temperatures (C)
    b += pack_floats([s.tcp_speed, *s.qd])  # 252..284
    b += struct.pack(">I", s.counter & 0xFFFFFFFF)
    b += pack_floats(s.world_offset)  # 288..312
    # GPIO reset on stop (control box, tool), simulation robot, collision detection, collision tool type
    b += bytes([0, 0, int(s.simulation_robot), 1, 0])
    b += pack_floats(np.zeros(6))  # collision tool model parameters
    b += struct.pack(">7H", *([4800] * 7))  # joint voltages (V * 100)
    b += pack_floats(np.zeros(7))  # joint currents
    b += bytes([0, 0]) + struct.pack(">8H", 0xFFFF, 0xFFFF, 0, 0, 0, 0, 0, 0)  # control box GPIO module
    b += bytes(32)  # its input / output functions (2 x 16)
    b += pack_floats(np.zeros(12))  # force/torque sensor: external, raw
    b += bytes([0])  # identification progress
    b += pack_floats(s.rotvec)  # 482..494
    b += bytes([0, 0])  # config bits, reduced mode
    b += struct.pack(">6h", 9999, -9999, 9999, -9999, 9999, -9999)  # reduced-mode TCP boundary
    b += pack_floats([0.0, 0.0]) + pack_floats(s.limits)  # reduced speeds, joint ranges (516..572)
    b += bytes([0, 0]) + struct.pack(">I", 0) + bytes([0, 0, 0]) + struct.pack(">3h", 0, 0, 0)
    assert len(b) == RICH_SIZE, len(b)
    return bytes(b)
