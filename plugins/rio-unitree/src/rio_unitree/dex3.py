"""The Dex3-1 hand as its DDS protocol numbers it: one table that the hand driver and the bridge share.

Each hand is its own device on its own topics: `rt/dex3/<side>/cmd` (unitree_hg `HandCmd_`: 7
`MotorCmd_`) and `rt/dex3/<side>/state` (`HandState_`: 7 `MotorState_`, its pressure sensors, an IMU,
power). No CRC (the hand messages have none). Motor order (HandCmd index 0-6, Unitree's, as its
xr_teleoperate `Dex3_1_{Left,Right}_JointIndex` and rio-sim's G1 model number them):

    left:  thumb 0, thumb 1, thumb 2, middle 0, middle 1, index 0, index 1
    right: thumb 0, thumb 1, thumb 2, index 0,  index 1,  middle 0, middle 1

Each motor's `mode` byte is a bit field (Unitree's `RIS_Mode`): bits 0-3 the motor's id (its index),
bits 4-6 its status (1: enabled, 0: off), bit 7 the timeout flag (left 0, as xr_teleoperate sends it).

Limits are Unitree's URDF's (g1_29dof_with_hand: the same in rio-sim's model), which sit inside the
table of Unitree's g1_dex3_example. Effort limits are the URDF's (thumb rotation 2.45 N·m, the others
1.4 N·m). Default gains are xr_teleoperate's Dex3-1 controller's (kp 1.5, kd 0.2); damping (kp = 0)
uses kd 0.1.
"""

from __future__ import annotations

from dataclasses import dataclass

from .joint_table import pick

NUM_MOTORS = 7
SIDES = ("left", "right")
_ORDER = {"left": ("thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1"),
          "right": ("thumb_0", "thumb_1", "thumb_2", "index_0", "index_1", "middle_0", "middle_1")}

KP, KD, DAMPING_KD = 1.5, 0.2, 0.1
STATUS_ON, STATUS_OFF = 1, 0


@dataclass(frozen=True)
class HandJoint:
    name: str
    index: int  # motor id, HandCmd index
    lower: float
    upper: float
    effort: float


# (lower, upper) of the left hand's joints; the right hand mirrors them (negated and swapped)
_LEFT_LIMITS = {"thumb_0": (-1.0472, 1.0472), "thumb_1": (-0.610865, 1.0472), "thumb_2": (0.0, 1.74533),
                "middle_0": (-1.5708, 0.0), "middle_1": (-1.74533, 0.0), "index_0": (-1.5708, 0.0),
                "index_1": (-1.74533, 0.0)}


def _limits(side: str, joint: str) -> tuple[float, float]:
    lo, hi = _LEFT_LIMITS[joint]
    if side == "left" or joint == "thumb_0":  # thumb 0 turns about the same axis on both hands
        return lo, hi
    return (-hi if hi else 0.0), (-lo if lo else 0.0)


def joints(side: str) -> tuple[HandJoint, ...]:
    """The hand's joints in motor order."""
    if side not in SIDES:
        raise ValueError(f"a Dex3-1 is 'left' or 'right', not {side!r}")
    return tuple(HandJoint(f"{side}_hand_{j}_joint", i, *_limits(side, j), 2.45 if j == "thumb_0" else 1.4)
                 for i, j in enumerate(_ORDER[side]))


def joint_names(side: str) -> list[str]:
    return [j.name for j in joints(side)]


def lookup(side: str, names: list[str]) -> list[HandJoint]:
    return pick(joints(side), names, f"Dex3-1 {side}")


def cmd_topic(side: str) -> str:
    return f"rt/dex3/{side}/cmd"


def state_topic(side: str) -> str:
    return f"rt/dex3/{side}/state"


def mode_byte(motor_id: int, status: int = STATUS_ON, timeout: int = 0) -> int:
    """A MotorCmd_ `mode` for the Dex3-1: id (bits 0-3) | status (bits 4-6) | timeout (bit 7)."""
    return (motor_id & 0x0F) | ((status & 0x07) << 4) | ((timeout & 0x01) << 7)


def parse_mode(mode: int) -> tuple[int, int, int]:
    """(id, status, timeout) of a `mode` byte."""
    mode = int(mode)
    return mode & 0x0F, (mode >> 4) & 0x07, (mode >> 7) & 0x01
