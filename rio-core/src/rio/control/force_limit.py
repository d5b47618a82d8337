"""Force and torque limits on a measured wrench: what a commander checks each cycle (`_Commander.guard`)
before it steps, for an arm whose station sets `force_limit` (`rio.interfaces.arm`).

A wrench is 6 values: force (N) then torque (N m), the external load at the tool as a wrist force/torque
sensor or the driver's estimate measures it, with its zero taken when the arm was enabled. Each limit bounds
the vector's magnitude (the direction of a collision is not known in advance); a limit left unset is not
checked. A NaN wrench (nothing measured this cycle) exceeds nothing here; a source that stays silent (a
separate sensor node) is judged by the arm, which holds through the same guard (`rio.interfaces.wrench_peer`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ForceLimit:
    force_n: float | None = None
    torque_nm: float | None = None

    def exceeded(self, wrench) -> str | None:
        """What is over its limit, in words ("force 41.3 N > 40 N"), or None when the wrench is within both."""
        w = np.asarray(wrench, dtype=np.float64).reshape(6)
        f, t = float(np.linalg.norm(w[:3])), float(np.linalg.norm(w[3:]))
        over = []
        if self.force_n is not None and not math.isnan(f) and f > self.force_n:
            over.append(f"force {f:.1f} N > {self.force_n:g} N")
        if self.torque_nm is not None and not math.isnan(t) and t > self.torque_nm:
            over.append(f"torque {t:.2f} N m > {self.torque_nm:g} N m")
        return ", ".join(over) or None
