"""What every workflow reports when it ends (`RunSummary`), and the measurements behind it.

One summary for teleop, leader-follower, deploy, replay and a user's own controller, so each figure
means the same thing everywhere:

- loop timing: wake-up lateness of each periodic tick (p50/p99/max, microseconds), late ticks (a
  step that ran past its cycle), overruns (whole cycles skipped: the loop re-anchored);
- tracking, per arm: the error between what was commanded *for* a time and what was measured *at*
  that time (joints in rad, tool position in m; max / mean / final), and the path the tool travelled
  next to the path it was commanded to travel. Comparing only the final pose with the final target
  reports success for an arm that never moved, when the target never moved either;
- per arm with a force limit, how many times it held the arm (`force_holds`), and, where a separate wrench
  node feeds the limit, how many of those because that node was silent or gone (`source_holds`);
- per-node publishing rates over the run, and ground-truth object motion where a simulator tells it;
- the task's verdict where a sensor runs one (a sim world with a task): `success` (None without a task)
  and `task` (the episode's seed and start, its task time, when success was first seen), from
  `Env.task_result()`; the same dict goes into the recorded episode's metadata.

A run in which an arm was commanded to move but did not follow sets `followed = False`: the summary
says so in a warning line and the command-line workflows exit with status 3 (docs/controllers.md).

What went wrong with a node during the run is in `events` (`NodeEvent`: a node that stopped with an error,
a fault it reported, a link it lost, a safety stop that disabled it), shown at the top of `format()`; a
run with any of them did not end as asked, whatever its `reason` says, and the command exits non-zero
(`rio.cli.exit_status`, one table for every workflow).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: An arm "did not follow" when it was commanded over at least this path (m, or rad for joint-only arms)
#: and travelled less than `_FOLLOW_FRACTION` of it.
_MIN_COMMANDED_M, _MIN_COMMANDED_RAD, _FOLLOW_FRACTION = 0.01, 0.05, 0.2


@dataclass
class ArmTracking:
    """Commanded versus measured for one arm over a run. `end`/`start`: measured tool poses (7: xyz +
    wxyz; NaN where the driver measures none); `target`: the last commanded tool pose (eef arms)."""

    role: str
    space: str
    start: np.ndarray
    end: np.ndarray
    target: np.ndarray | None = None
    path_m: float = 0.0
    commanded_path_m: float = 0.0
    joint_path_rad: float = 0.0
    commanded_joint_path_rad: float = 0.0
    joint_err_rad: tuple[float, float, float] | None = None  # max, mean, final
    eef_err_m: tuple[float, float, float] | None = None
    gripper: float | None = None
    #: the measured joints at the end
    final_q: np.ndarray | None = None
    #: times the arm's force limit held it during the run (None: the arm has no force limit)
    force_holds: int | None = None
    #: of those, the times its wrench source (a separate node) was silent or gone (None: no such source)
    source_holds: int | None = None
    #: commands the run sent the arm, and how many of them its workspace box cut (`rio.control.workspace`;
    #: None: the arm does not say)
    commands: int = 0
    clipped: int | None = None

    @property
    def followed(self) -> bool:
        if self.commanded_path_m >= _MIN_COMMANDED_M and math.isfinite(self.path_m):
            return self.path_m >= _FOLLOW_FRACTION * self.commanded_path_m
        if self.commanded_joint_path_rad >= _MIN_COMMANDED_RAD:
            return self.joint_path_rad >= _FOLLOW_FRACTION * self.commanded_joint_path_rad
        return True  # not commanded to move: nothing to follow


#: `NodeEvent.kind`s, the most serious first (the order `RunSummary.problem` and the exit status follow).
ERROR, FAULT, LINK, DISABLED = "error", "fault", "link", "disabled"
EVENT_KINDS = (ERROR, FAULT, LINK, DISABLED)
_EVENT_LABELS = {ERROR: "ERROR", FAULT: "FAULT", LINK: "LINK LOST", DISABLED: "SAFETY STOP"}


@dataclass
class NodeEvent:
    """Something that went wrong with a node during a run: it stopped with an error (`error`), its device
    reported a fault (`fault`), its link dropped (`link`), or it was disabled without the workflow asking (a
    safety stop: an emergency stop, a watchdog, another client: `disabled`). `t_s`: seconds into the run
    (None: before it or after it); `message`: what happened, naming the cause where it is known."""

    kind: str
    node: str
    message: str
    t_s: float | None = None

    def line(self) -> str:
        at = f" at {self.t_s:.1f} s" if self.t_s is not None else ""
        return f"{_EVENT_LABELS.get(self.kind, self.kind.upper())}: node '{self.node}'{at}: {self.message}"


@dataclass
class ObjectMotion:
    """A simulated object's ground truth over the run (poses: xyz + wxyz)."""

    name: str
    start: np.ndarray
    end: np.ndarray
    max_z: float


@dataclass
class RunSummary:
    workflow: str
    station: str
    reason: str = ""
    rate_hz: float = 0.0
    seconds: float = 0.0
    ticks: int = 0
    late_ticks: int = 0
    overruns: int = 0
    #: wake-up lateness of the periodic ticks, microseconds
    lateness_us: dict[str, float] = field(default_factory=dict)
    instruction: str | None = None
    arms: list[ArmTracking] = field(default_factory=list)
    objects: list[ObjectMotion] = field(default_factory=list)
    #: samples per second each node published during the run
    node_rates_hz: dict[str, float] = field(default_factory=dict)
    #: whether the episode's task succeeded at the end of the run; None: the station runs no task
    success: bool | None = None
    #: the task's episode: seed, episode, episode_seed, start poses, time_s, first_success_s, time_limit_s
    task: dict[str, Any] = field(default_factory=dict)
    #: the signal that ended the run (SIGINT, SIGTERM, SIGHUP), if one did
    signal: str | None = None
    #: what the workflow adds: deploy's inference stats, replay's episode, leader-follower alignment...
    details: dict[str, Any] = field(default_factory=dict)
    #: the workflow's own lines for `format()`
    lines: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    #: what went wrong with a node during the run (`NodeEvent`), in the order it was seen
    events: list[NodeEvent] = field(default_factory=list)

    def add_event(self, kind: str, node: str, message: str, t_s: float | None = None) -> NodeEvent:
        """Record what went wrong with `node` (one event per node and kind: the first is what matters)."""
        for e in self.events:
            if e.kind == kind and e.node == node:
                return e
        event = NodeEvent(kind, node, message, None if t_s is None else round(float(t_s), 3))
        self.events.append(event)
        return event

    @property
    def problem(self) -> str | None:
        """The most serious kind of event of the run (`EVENT_KINDS` order), None when nothing went wrong."""
        kinds = {e.kind for e in self.events}
        return next((k for k in EVENT_KINDS if k in kinds), None)

    @property
    def achieved_hz(self) -> float:
        return self.ticks / self.seconds if self.seconds > 0 else 0.0

    @property
    def followed(self) -> bool:
        return all(a.followed for a in self.arms)

    def format(self) -> str:
        lat = self.lateness_us
        device = f" with {self.details['device']}" if "device" in self.details else ""
        out = [f"{self.workflow} on '{self.station}'{device}: {self.reason}"]
        out += ["  " + e.line() for e in self.events]  # at the top: what went wrong comes first
        if self.rate_hz > 0:  # a loop ran (`rio serve` runs none)
            out.append(f"  {self.seconds:.1f} s, {self.ticks} ticks at {self.achieved_hz:.1f} Hz (target "
                       f"{self.rate_hz:g} Hz), {self.late_ticks} late, {self.overruns} overruns"
                       + (f"; wake-up lateness p50 {lat['p50']:.0f} us, p99 {lat['p99']:.0f} us, max "
                          f"{lat['max']:.0f} us" if lat else ""))
        if self.instruction:
            out.append(f"  instruction: {self.instruction}")
        for a in self.arms:
            out.append("  " + _arm_line(a))
        moved = [o for o in self.objects if _moved(o)]
        out += [f"  {o.name}: moved {np.linalg.norm(o.end[:3] - o.start[:3]) * 100:.1f} cm to {_v(o.end[:3])} m, "
                f"lifted up to {(o.max_z - o.start[2]) * 100:.1f} cm" for o in moved]
        if self.objects and not moved:
            out.append("  no object moved")
        if self.success is not None:
            out.append("  " + _task_line(self.success, self.task))
        if self.node_rates_hz:
            out.append("  node rates: " + ", ".join(f"{n} {hz:.0f} Hz" for n, hz in self.node_rates_hz.items()))
        out += ["  " + line for line in self.lines]
        out += [f"  WARNING: {w}" for w in self.warnings]
        return "\n".join(out)

    def to_json(self) -> dict[str, Any]:
        """Plain JSON types only (`--json`)."""
        d = {f.name: plain(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "lines"}
        d.update(achieved_hz=round(self.achieved_hz, 3), followed=self.followed, problem=self.problem)
        for a, arm in zip(d["arms"], self.arms, strict=True):
            a["followed"] = arm.followed
        return d


def _arm_line(a: ArmTracking) -> str:
    parts = [f"{a.role}:"]
    if np.isfinite(a.end[:3]).all():
        parts.append(f"tool {_v(a.start[:3])} -> {_v(a.end[:3])} m, path {a.path_m:.3f} m"
                     + (f" of {a.commanded_path_m:.3f} m commanded;" if a.space == "eef_pose" else ";"))
    if a.space == "joint_pos":
        parts.append(f"joints moved {a.joint_path_rad:.3f} rad of {a.commanded_joint_path_rad:.3f} rad commanded;")
    if a.eef_err_m is not None:
        mx, mean, final = a.eef_err_m
        parts.append(f"tool error max {mx * 1000:.1f} / mean {mean * 1000:.1f} / final {final * 1000:.1f} mm;")
    if a.joint_err_rad is not None:
        mx, mean, final = a.joint_err_rad
        parts.append(f"joint error max {mx:.3f} / mean {mean:.3f} / final {final:.3f} rad;")
    if a.gripper is not None:
        parts.append(f"gripper {a.gripper * 1000:.0f} mm;")
    if a.force_holds:
        silent = f" ({a.source_holds} with its wrench source silent or gone)" if a.source_holds else ""
        parts.append(f"force limit held it {a.force_holds} time{'s' if a.force_holds != 1 else ''}{silent};")
    if a.clipped:
        parts.append(f"{a.clipped} of {a.commands} commands clipped to its workspace;")
    if not a.followed:
        parts.append("DID NOT FOLLOW its commands;")
    return " ".join(parts).rstrip(";")


def _task_line(success: bool, task: dict[str, Any]) -> str:
    limit = f" of {task['time_limit_s']:g} s" if task.get("time_limit_s") else ""
    first = task.get("first_success_s")
    verdict = (f"SUCCESS (first at {first:.1f} s{limit})" if success and first is not None else "SUCCESS" if success
               else f"FAILED after {task.get('time_s', 0.0):.1f} s{limit}"
               + (f" (it had succeeded at {first:.1f} s)" if first is not None else ""))
    seeds = ", ".join(f"{k} {task[k]}" for k in ("seed", "episode", "episode_seed") if task.get(k) is not None)
    kind = f" {task['kind']}" if task.get("kind") else ""
    return f"task{kind}: {verdict}" + (f"; {seeds}" if seeds else "")


def _moved(o: ObjectMotion) -> bool:
    return bool(np.linalg.norm(o.end[:3] - o.start[:3]) > 0.005 or o.max_z - o.start[2] > 0.005)


def _v(x: Any) -> str:
    return "(" + ", ".join(f"{c:+.3f}" for c in x) + ")"


def plain(x: Any) -> Any:
    """`x` in plain JSON types: dataclasses and dicts as dicts, arrays and tuples as lists, NaN/inf as None."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: plain(getattr(x, f.name)) for f in dataclasses.fields(x)}
    if isinstance(x, dict):
        return {str(k): plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return [plain(v) for v in x.tolist()]
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(float(x)) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x
