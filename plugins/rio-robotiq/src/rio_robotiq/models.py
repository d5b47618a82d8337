"""The gripper models this plugin drives, and the one place where SI units meet register units.

Drivers and emulators both read these tables, so a stroke or a range is written once. Figures are
the vendors' specification tables (Robotiq 2F-85 & 2F-140 and Hand-E instruction manuals; DH-Robotics
AG-160-95 and AG-105-145 data sheets). Register scales are linear, as the manuals describe them;
Robotiq notes its force scale is only approximately linear, so forces in N are nominal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class GripperModel:
    key: str
    label: str
    #: full opening between the fingers (m)
    stroke: float
    #: finger speed at the lowest and highest speed setting (m/s)
    speed_range: tuple[float, float]
    #: grip force at the lowest and highest force setting (N)
    force_range: tuple[float, float]

    @property
    def max_speed(self) -> float:
        return self.speed_range[1]


ROBOTIQ_MODELS: dict[str, GripperModel] = {
    "2f85": GripperModel("2f85", "Robotiq 2F-85", 0.085, (0.020, 0.150), (20.0, 235.0)),
    "2f140": GripperModel("2f140", "Robotiq 2F-140", 0.140, (0.030, 0.250), (10.0, 125.0)),
    "hande": GripperModel("hande", "Robotiq Hand-E", 0.050, (0.020, 0.150), (20.0, 185.0)),
}

#: DH names its adaptive grippers AG-<max force N>-<stroke mm>: "AG-95" is the AG-160-95 and "AG-105"
#: the AG-105-145 (145 mm stroke, not 105). Both open or close fully in 0.7 s at 100 % speed.
DH_MODELS: dict[str, GripperModel] = {
    "ag95": GripperModel("ag95", "DH-Robotics AG-95 (AG-160-95)", 0.095, (0.095 / 0.7 * 0.01, 0.095 / 0.7),
                         (45.0, 160.0)),
    "ag105": GripperModel("ag105", "DH-Robotics AG-105-145", 0.145, (0.145 / 0.7 * 0.01, 0.145 / 0.7),
                          (35.0, 105.0)),
}


def clip(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


# -- Robotiq: 0..255 registers -------------------------------------------------------------------------
def robotiq_counts(width: float, stroke: float, open_count: int = 0, closed_count: int = 255) -> int:
    """Opening (m) -> position request rPR. Robotiq counts run the other way: 0 is open, 255 closed."""
    frac = clip(width / stroke, 0.0, 1.0)
    return int(round(closed_count - (closed_count - open_count) * frac))


def robotiq_width(counts: int, stroke: float, open_count: int = 0, closed_count: int = 255) -> float:
    """Position gPO -> opening (m), clipped to [0, stroke] (a unit reads a few counts past its ends)."""
    return clip((closed_count - counts) / (closed_count - open_count), 0.0, 1.0) * stroke


def scale_to_byte(value: float, lo: float, hi: float) -> int:
    """A speed (m/s) or force (N) -> its 0..255 setting, linear over the model's range."""
    return int(round(clip((value - lo) / (hi - lo), 0.0, 1.0) * 255))


def byte_to_scale(setting: int, lo: float, hi: float) -> float:
    return lo + (hi - lo) * clip(setting, 0, 255) / 255.0


# -- DH: per-mille position, per-cent force and speed ---------------------------------------------------
DH_FORCE_PCT = (20, 100)
DH_SPEED_PCT = (1, 100)


def dh_permille(width: float, stroke: float) -> int:
    """Opening (m) -> position register (per mille of the stroke; 0 closed, 1000 open)."""
    return int(round(clip(width / stroke, 0.0, 1.0) * 1000))


def dh_width(permille: int, stroke: float) -> float:
    return clip(permille / 1000.0, 0.0, 1.0) * stroke


def dh_force_pct(force: float, max_force: float) -> int:
    """Grip force (N) -> force register (per cent of the model's maximum, 20..100)."""
    if math.isnan(force):
        raise ValueError("force is NaN")
    return int(round(clip(force / max_force * 100.0, *DH_FORCE_PCT)))


def dh_speed_pct(speed: float, max_speed: float) -> int:
    """Finger speed (m/s) -> speed register (per cent of the model's fastest, 1..100)."""
    return int(round(clip(speed / max_speed * 100.0, *DH_SPEED_PCT)))
