"""Forward kinematics straight from the DH table: the reference the MJCF is checked against, and how
the emulator computes the TCP pose it reports (as the controller computes its own from its DH)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from rio.control import matrix_to_pose

from .models import URModel


def dh_link(a: float, d: float, alpha: float, theta: float) -> np.ndarray:
    """Standard DH: Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def flange_matrix(model: URModel, q: Sequence[float]) -> np.ndarray:
    t = np.eye(4)
    for a, d, alpha, theta in zip(model.a, model.d, model.alpha, q, strict=True):
        t = t @ dh_link(a, d, alpha, float(theta))
    return t


def flange_pose(model: URModel, q: Sequence[float]) -> np.ndarray:
    """The flange `[x, y, z, qw, qx, qy, qz]` (m) in the base frame at joints `q` (rad)."""
    return matrix_to_pose(flange_matrix(model, q))
