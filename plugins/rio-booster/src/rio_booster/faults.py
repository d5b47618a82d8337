"""What stops the T1 driver by itself, named (`rio.interfaces.Fault`), and the IMU arithmetic that detects a
fall (the T1 reports its trunk orientation as roll, pitch, yaw: `ImuState.rpy`).

Each fault leaves the node disabled, sending damping (kp = 0) and asking the robot for its damping mode
(`B1LocoClient.ChangeMode(kDamping)`), until `clear_faults()`, which refuses while the cause lasts.
"""

from __future__ import annotations

import math

import numpy as np
from rio.interfaces import Fault

LOWSTATE_TIMEOUT, FALL, STALE_COMMANDS = 1, 2, 3


def lowstate_timeout(seconds: float, interface: str, domain_id: int) -> Fault:
    return Fault(LOWSTATE_TIMEOUT, "lowstate_timeout",
                 f"no rt/low_state for {seconds:.2f} s on interface '{interface}' (DDS domain {domain_id})",
                 "check the cable, the interface's address (192.168.10.x) and that the robot is on; "
                 "clear_faults() once it publishes again")


def fall(tilt: float, limit_deg: float) -> Fault:
    return Fault(FALL, "fall", f"the trunk is tilted {tilt:.0f} deg from upright (fall_tilt_deg {limit_deg:.0f}): "
                               "damping", "hang or stand the robot upright, then clear_faults()")


def stale_commands(watchdog_s: float) -> Fault:
    return Fault(STALE_COMMANDS, "stale_commands",
                 f"the stream of commands stopped for more than watchdog_s ({watchdog_s} s): damping",
                 "clear_faults() or enable() holds where the robot is; then command again")


def rpy_to_quat(rpy: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (rad; the body's rotation is Rz(yaw) Ry(pitch) Rx(roll)) as a quaternion [w, x, y, z]."""
    r, p, y = (0.5 * float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def tilt_deg(rpy: np.ndarray) -> float:
    """Angle between the trunk's up axis and the world's (deg); yaw never counts."""
    r, p = float(rpy[0]), float(rpy[1])
    if not (math.isfinite(r) and math.isfinite(p)):
        return math.nan
    return math.degrees(math.acos(max(-1.0, min(1.0, math.cos(r) * math.cos(p)))))


def quat_to_rpy(quat_wxyz: np.ndarray) -> np.ndarray:
    """The inverse of `rpy_to_quat` (roll, pitch, yaw in rad)."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.array([roll, pitch, yaw])
