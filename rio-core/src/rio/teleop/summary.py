"""What a teleop run reports when it ends: how long, how regular the loop was, where each arm went,
and (when the station has a simulator's ground truth) which objects moved."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class ArmReport:
    role: str
    start: np.ndarray
    end: np.ndarray
    target: np.ndarray
    path_m: float
    gripper: float | None


@dataclass
class ObjectReport:
    name: str
    start: np.ndarray
    end: np.ndarray
    max_z: float


@dataclass
class TeleopSummary:
    station: str
    device: str
    reason: str
    seconds: float = 0.0
    ticks: int = 0
    rate_hz: float = 0.0
    late_ticks: int = 0
    max_late_ms: float = 0.0
    instruction: str | None = None
    arms: list[ArmReport] = field(default_factory=list)
    objects: list[ObjectReport] = field(default_factory=list)
    viz: str | None = None

    @property
    def achieved_hz(self) -> float:
        return self.ticks / self.seconds if self.seconds > 0 else 0.0

    def format(self) -> str:
        def v(x) -> str:
            return "(" + ", ".join(f"{c:+.3f}" for c in x) + ")"

        lines = [f"teleop on '{self.station}' with {self.device}: {self.reason}",
                 f"  {self.seconds:.1f} s, {self.ticks} steps at {self.achieved_hz:.1f} Hz "
                 f"(target {self.rate_hz:g} Hz), "
                 f"{self.late_ticks} late (worst {self.max_late_ms:.1f} ms)"]
        if self.instruction:
            lines.append(f"  instruction: {self.instruction}")
        for a in self.arms:
            err = float(np.linalg.norm(a.end[:3] - a.target[:3])) * 1000
            grip = "" if a.gripper is None else f", gripper {a.gripper * 1000:.0f} mm"
            lines.append(f"  {a.role}: tool {v(a.start[:3])} -> {v(a.end[:3])} m, path {a.path_m:.3f} m, "
                         f"{err:.1f} mm from target{grip}")
        moved_any = False
        for o in self.objects:
            moved = float(np.linalg.norm(o.end[:3] - o.start[:3]))
            if moved > 0.005 or o.max_z - o.start[2] > 0.005:
                moved_any = True
                lines.append(f"  {o.name}: moved {moved * 100:.1f} cm to {v(o.end[:3])} m, "
                             f"lifted up to {(o.max_z - o.start[2]) * 100:.1f} cm")
        if self.objects and not moved_any:
            lines.append("  no object moved")
        if self.viz:
            lines.append(f"  viz: {self.viz}")
        return "\n".join(lines)
