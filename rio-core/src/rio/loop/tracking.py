"""Measurements the control loop takes every tick for its summary: did each arm follow its commands,
and did any object move.

A command is meant for its target time (`t_cmd_target`, a cycle or more ahead), so comparing it with
the state measured at the tick it was sent would count the planned lead as error. `ArmTracker` keeps
the commands in flight and compares each measurement with the newest command whose target time has
passed: the error a user sees is the arm's actual lag behind the plan.
"""

from __future__ import annotations

import collections
from typing import Any

import numpy as np

from rio import clock
from rio.control.reservoir import Reservoir
from rio.embodiments.arm_group import ACTION_SPACES
from rio.errors import NodeDiedError
from rio.loop.summary import ArmTracking, ObjectMotion

ARM_ROLES = ("arm", "arm2")


def arm_labels(robot: Any) -> list[tuple[str, str]]:
    """(action label, space) of each arm part of an embodiment's action (`<prefix>joint_pos` or
    `<prefix>eef_pose`), in action order."""
    return [(label, s) for label, _ in robot.action_parts() for s in ACTION_SPACES if label.endswith(s)]


def arm_roles(robot: Any) -> list[str]:
    """The embodiment's arm roles, in the order their parts appear in the action."""
    return [r for r in ARM_ROLES if r in robot.clients]


def arm_parts(robot: Any) -> list[tuple[str, str, str]]:
    """(role, action label, space) of each arm, parts matched to roles in order (what of them there is)."""
    return [(r, label, s) for r, (label, s) in zip(arm_roles(robot), arm_labels(robot), strict=False)]


class _Arm:
    def __init__(self, role: str, label: str, space: str, client: Any, gripper: Any):
        self.role, self.label, self.space, self.client, self.gripper = role, label, space, client, gripper
        s = client.get_state()
        self.start = np.asarray(s["eef_pose"], dtype=np.float64).copy()
        self.last_tool, self.last_q = self.start[:3].copy(), np.asarray(s["joint_pos"], dtype=np.float64).copy()
        self.pending: collections.deque[tuple[float, np.ndarray]] = collections.deque()
        self.due: np.ndarray | None = None
        self.last_cmd: np.ndarray | None = None
        #: where the commanded path starts: the arm as it stood (so the first command's jump counts, as the
        #: measured path counts the arm's move to it)
        self.from_cmd = self.start.copy() if space == "eef_pose" else self.last_q.copy()
        self.errors = Reservoir()  # only max and mean are reported; both exact
        holds = s.get("force_holds")  # an arm with a force limit: counted from here
        self.holds0 = None if holds is None else int(holds)
        silent = s.get("source_holds")  # an arm whose force limit reads a separate wrench node
        self.silent0 = None if silent is None else int(silent)
        self.path = self.cmd_path = self.joint_path = self.cmd_joint_path = 0.0
        #: targets the arm's workspace box had cut before the run (its samples count since the node opened)
        self.clipped_before = int(s["clipped"]) if "clipped" in s else None
        self.commands = 0

    def command(self, part: np.ndarray, t_target: float) -> None:
        part = np.asarray(part, dtype=np.float64)
        prev = self.from_cmd if self.last_cmd is None else self.last_cmd
        if self.space == "eef_pose":
            if np.isfinite(prev[:3]).all():
                self.cmd_path += float(np.linalg.norm(part[:3] - prev[:3]))
        elif prev.shape == part.shape:
            self.cmd_joint_path += float(np.linalg.norm(part - prev))
        self.last_cmd = part.copy()
        self.commands += 1
        self.pending.append((t_target, self.last_cmd))

    def _error(self, cmd: np.ndarray, tool: np.ndarray, q: np.ndarray) -> float:
        if self.space == "eef_pose":
            return float(np.linalg.norm(cmd[:3] - tool[:3]))
        return float(np.max(np.abs(cmd - q))) if cmd.shape == q.shape else float("nan")

    def measure(self, t: float) -> None:
        s = self.client.get_state()
        tool, q = np.asarray(s["eef_pose"], dtype=np.float64), np.asarray(s["joint_pos"], dtype=np.float64)
        if np.isfinite(tool[:3]).all() and np.isfinite(self.last_tool).all():
            self.path += float(np.linalg.norm(tool[:3] - self.last_tool))
        self.joint_path += float(np.linalg.norm(q - self.last_q)) if q.shape == self.last_q.shape else 0.0
        self.last_tool, self.last_q = tool[:3].copy(), q.copy()
        while self.pending and self.pending[0][0] <= t:
            self.due = self.pending.popleft()[1]
        if self.due is not None:
            self.errors.add(self._error(self.due, tool, q))

    def report(self) -> ArmTracking:
        s = self.client.get_state()
        tool, q = np.asarray(s["eef_pose"], dtype=np.float64).copy(), np.asarray(s["joint_pos"], dtype=np.float64)
        errs = self.errors
        final = self._error(self.last_cmd, tool, q) if self.last_cmd is not None else float("nan")
        stats = (errs.max, errs.mean, final) if errs.mean is not None else None
        g = None if self.gripper is None else float(self.gripper.get_state()["position"])
        holds = None if self.holds0 is None else int(s["force_holds"]) - self.holds0
        silent = None if self.silent0 is None else int(s["source_holds"]) - self.silent0
        clipped = int(s["clipped"]) - self.clipped_before if self.clipped_before is not None else None
        return ArmTracking(self.role, self.space, self.start, tool,
                           self.last_cmd.copy() if self.space == "eef_pose" and self.last_cmd is not None else None,
                           self.path, self.cmd_path, self.joint_path, self.cmd_joint_path,
                           joint_err_rad=stats if self.space == "joint_pos" else None,
                           eef_err_m=stats if self.space == "eef_pose" else None, gripper=g, final_q=q.copy(),
                           force_holds=holds, source_holds=silent, commands=self.commands, clipped=clipped)


class ArmTracker:
    """Commanded versus measured for every arm of an embodiment (see the module docstring)."""

    def __init__(self, robot: Any):
        self.robot = robot
        self.arms = [_Arm(role, label, space, robot.clients[role], robot.clients.get("gripper" + role[3:]))
                     for role, label, space in arm_parts(robot)]

    def commanded(self, action: np.ndarray, t_target: float) -> None:
        parts = self.robot.split_action(action)
        for a in self.arms:
            a.command(parts[a.label], t_target)

    def measure(self, t: float) -> None:
        for a in self.arms:
            a.measure(t)

    def report(self) -> list[ArmTracking]:
        """Each arm's tracking; an arm whose node has stopped has none (the summary names that node)."""
        out = []
        for a in self.arms:
            try:
                out.append(a.report())
            except NodeDiedError:
                continue
        return out

    def wait_still(self, timeout: float, period: float = 0.05, tol_rad: float = 1e-4) -> bool:
        """Wait, at most `timeout` s, until no arm's joints move more than `tol_rad` in `period`: the run
        is measured once the last motion has ended, however long a loaded machine's (or a slow arm's)
        interpolation takes to get there. False when they were still moving at the timeout."""
        def joints() -> list[np.ndarray]:
            return [np.asarray(a.client.get_state()["joint_pos"], dtype=np.float64) for a in self.arms]

        prev, t_end = joints(), clock.now() + timeout
        while clock.now() < t_end:
            clock.precise_wait(clock.now() + period)
            cur = joints()
            if all(c.shape != p.shape or float(np.max(np.abs(c - p), initial=0.0)) < tol_rad
                   for c, p in zip(cur, prev, strict=True)):
                return True
            prev = cur
        return False


class ObjectWatch:
    """Ground-truth object poses from any sensor node that names objects (a simulator's world)."""

    def __init__(self, sensors: dict[str, Any]):
        self.sources = [(c, list(c.object_names())) for c in sensors.values() if "object_names" in dir(c)]
        self.max_z: dict[str, float] = {}
        self.last: dict[str, np.ndarray] = {}
        self.update()
        self.start = {k: v.copy() for k, v in self.last.items()}

    def update(self) -> None:
        for client, names in self.sources:
            poses = np.asarray(client.get_state()["object_poses"])
            for name, pose in zip(names, poses[:len(names)], strict=True):
                self.last[name] = pose.copy()
                self.max_z[name] = max(self.max_z.get(name, -np.inf), float(pose[2]))

    def report(self) -> list[ObjectMotion]:
        self.update()
        return [ObjectMotion(n, self.start[n], self.last[n], self.max_z[n]) for n in self.start]
