"""How far each stage of a teleop run moved: the device (what its samples add up to) and each arm's target
(after the low-pass, the speed limits and the workspace), next to the measured path of the summary.

A teleop target that does not travel as the device did is a bug somewhere between the two; with one
figure per stage, a run that ends away from where the device said shows which stage added or lost the
travel (`RunSummary.details["travel"]`, one line of `format()`).
"""

from __future__ import annotations

from typing import Any

import numpy as np


class Travel:
    """Path length and net displacement (m) of a sequence of position steps."""

    def __init__(self) -> None:
        self.path_m = 0.0
        self.net = np.zeros(3)

    def add(self, step: Any) -> None:
        step = np.asarray(step, dtype=np.float64).reshape(-1)[:3]
        if np.isfinite(step).all():
            self.path_m += float(np.linalg.norm(step))
            self.net += step

    def report(self) -> dict[str, Any]:
        return {"path_m": self.path_m, "net_m": [float(x) for x in self.net]}

    def describe(self) -> str:
        return f"path {self.path_m:.3f} m, ends {np.linalg.norm(self.net) * 1000:.1f} mm from its start"


def travel_line(stages: dict[str, Travel]) -> str:
    """One summary line: `travel: device 'teleop' path 0.200 m, ...; arm target path 0.200 m, ...`."""
    return "travel: " + "; ".join(f"{name} {t.describe()}" for name, t in stages.items())
