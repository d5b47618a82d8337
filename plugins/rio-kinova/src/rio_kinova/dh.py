"""Kinova's published Denavit-Hartenberg tables (classic DH: T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i),
theta_i = q_i + offset_i) and their forward kinematics.

The tables are the arms' user guides' ("Denavit-Hartenberg parameters" sections); they are the one source
of the MJCF models in `assets/` (written from them, see `mjcf.py`) and of the fake backend's tool pose,
and a test checks MuJoCo's forward kinematics of each MJCF against `fk()` here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

PI, HALF = math.pi, math.pi / 2


@dataclass(frozen=True)
class DH:
    alpha: float
    a: float
    d: float
    offset: float = 0.0  # theta_i = q_i + offset (the guides' "q_i + pi" entries)


#: Gen3 7-DOF (Gen3 user guide): a fixed base frame (alpha = pi: DH frame 0 has z down), then 7 joints;
#: the last frame is the interface module's flange (tool frame with no tool configured).
GEN3_7DOF_BASE = DH(PI, 0.0, 0.0)
GEN3_7DOF = (
    DH(HALF, 0.0, -(0.1564 + 0.1284)),
    DH(HALF, 0.0, -(0.0054 + 0.0064), PI),
    DH(HALF, 0.0, -(0.2104 + 0.2104), PI),
    DH(HALF, 0.0, -(0.0064 + 0.0064), PI),
    DH(HALF, 0.0, -(0.2084 + 0.1059), PI),
    DH(HALF, 0.0, 0.0, PI),
    DH(PI, 0.0, -(0.1059 + 0.0615), PI),
)

#: Gen3 6-DOF (Gen3 user guide, 6-DOF table): same base frame; joints 2-3 form a planar pair (a2 = 0.410).
GEN3_6DOF = (
    DH(HALF, 0.0, -(0.1564 + 0.1284)),
    DH(PI, 0.410, -(0.0054 + 0.0064), -HALF),
    DH(HALF, 0.0, -(0.0064 + 0.0064), -HALF),
    DH(HALF, 0.0, -(0.2084 + 0.1059), PI),
    DH(HALF, 0.0, 0.0, PI),
    DH(PI, 0.0, -(0.1059 + 0.0615), PI),
)

#: Gen3 lite (Gen3 lite user guide): no base frame; the last frame is the guide's end-effector frame.
GEN3_LITE = (
    DH(HALF, 0.0, 0.1283 + 0.1150),
    DH(PI, 0.280, 0.030, HALF),
    DH(HALF, 0.0, 0.020, HALF),
    DH(HALF, 0.0, 0.1400 + 0.1050, HALF),
    DH(HALF, 0.0, 0.0285 + 0.0285, PI),
    DH(0.0, 0.0, 0.1050 + 0.1300, HALF),
)


def link(p: DH, theta: float) -> np.ndarray:
    """One DH transform (4x4)."""
    import numpy as np  # here: the tables are read by the plugin's entry module, which must not load numpy

    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(p.alpha), math.sin(p.alpha)
    return np.array([[ct, -st * ca, st * sa, p.a * ct],
                     [st, ct * ca, -ct * sa, p.a * st],
                     [0.0, sa, ca, p.d],
                     [0.0, 0.0, 0.0, 1.0]])


def fk(table: tuple[DH, ...], q, base: DH | None = None) -> np.ndarray:
    """The last frame's pose in the base frame (4x4) at joint positions `q` (rad)."""
    import numpy as np

    t = np.eye(4) if base is None else link(base, base.offset)
    for p, qi in zip(table, np.asarray(q, dtype=np.float64), strict=True):
        t = t @ link(p, float(qi) + p.offset)
    return t
