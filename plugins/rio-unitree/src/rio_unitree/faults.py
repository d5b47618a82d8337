"""What stops the G1 driver by itself, named (`rio.interfaces.Fault`), and the tilt that detects a fall.

The G1 reports no faults of its own on rt/lowstate that a driver could act on; these are the driver's
own safety stops. Each one leaves the node disabled (lowcmd: damping on the wire; arm_sdk: the arms
handed back to Unitree's controller) until `clear_faults()`, which refuses while the cause lasts.
"""

from __future__ import annotations

import math

import numpy as np
from rio.interfaces import Fault

LOWSTATE_TIMEOUT, FALL, STALE_COMMANDS = 1, 2, 3


def lowstate_timeout(seconds: float, interface: str, domain_id: int) -> Fault:
    return Fault(LOWSTATE_TIMEOUT, "lowstate_timeout",
                 f"no rt/lowstate for {seconds:.2f} s on interface '{interface}' (DDS domain {domain_id})",
                 "check the cable, the interface's address (192.168.123.x) and that the robot is on; "
                 "clear_faults() once it publishes again")


def fall(tilt_deg: float, limit_deg: float) -> Fault:
    return Fault(FALL, "fall", f"the pelvis is tilted {tilt_deg:.0f} deg from upright (fall_tilt_deg "
                               f"{limit_deg:.0f}): damping",
                 "hang or stand the robot upright, then clear_faults()")


def stale_commands(watchdog_s: float) -> Fault:
    return Fault(STALE_COMMANDS, "stale_commands",
                 f"the stream of commands stopped for more than watchdog_s ({watchdog_s} s): damping",
                 "clear_faults() or enable() holds where the robot is; then command again")


def tilt_deg(quat_wxyz: np.ndarray) -> float:
    """Angle between the body's up axis and the world's (deg): from the gravity direction the IMU
    quaternion projects into the body frame, so yaw never counts."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    n = w * w + x * x + y * y + z * z
    if not math.isfinite(n) or n < 1e-9:
        return math.nan
    up_z = 1.0 - 2.0 * (x * x + y * y) / n  # z component of the body's z axis in the world frame
    return math.degrees(math.acos(max(-1.0, min(1.0, up_z))))
