"""Leader-follower teleop: each follower arm mirrors the joint angles of its leader arm.

Written against `Env` and node clients only (no SO-100 specifics), so it drives any station whose
teleop device(s) publish `joint_pos` (a leader arm) and whose arms take joint actions: one pair
(`teleop` -> `arm` [+ `gripper`]) or ALOHA-style two (`teleop2` -> `arm2` [+ `gripper2`]).

Start-up alignment: a follower is rarely where its leader is when the run starts, and mirroring at
once would snap it across. So each arm first moves towards its leader at `align_speed` (rad/s; the
jaw at `align_speed` of its range per second), chasing the leader if it moves, until every joint is
within `align_tolerance`; from then on it mirrors the leader each cycle. Loop timing is the RIO
the one control loop's (`rio.loop.control_loop`); `LeaderFollower` is its controller.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rio.embodiments.mobile import BASE_TWIST
from rio.errors import RioError
from rio.loop.tracking import arm_labels, arm_roles

PAIRS = (("teleop", "arm", "gripper"), ("teleop2", "arm2", "gripper2"))


@dataclass
class Pair:
    """One leader driving one follower (and its gripper)."""

    leader_role: str
    arm_role: str
    leader: Any
    arm_label: str
    gripper_label: str | None = None
    max_width: float = 0.0
    q_cmd: np.ndarray = field(default_factory=lambda: np.zeros(0))
    grip_cmd: float = 0.0
    aligned: bool = False
    t_aligned: float | None = None
    start_error: float = 0.0
    #: the leader's joints as the last command saw them: what "final error to the leader" compares with
    #: (the leader goes on moving while the run settles; the follower, no longer commanded, does not)
    q_lead_last: np.ndarray | None = None


def find_pairs(station: Any) -> list[tuple[str, str, str | None]]:
    """(leader role, arm role, gripper role or None) of each leader-follower pair of a station."""
    roles = station.roles()
    pairs = [(t, a, g if g in roles else None) for t, a, g in PAIRS if t in roles and a in roles]
    if not pairs:
        raise RioError(f"station '{station.name}' has no leader-follower pair: it needs a `teleop` leader arm and "
                       f"an `arm` (and `teleop2` + `arm2` for two); roles: {sorted(roles)}")
    return pairs


def _labels(robot: Any, pair_roles: list[str]) -> dict[str, tuple[str, str | None]]:
    layout = dict(robot.action_parts())
    joint_parts = [label for label, space in arm_labels(robot) if space == "joint_pos"]
    roles = arm_roles(robot)
    if len(joint_parts) != len(roles):
        raise RioError(f"leader-follower needs joint-position actions; embodiment '{robot.name}' takes "
                       f"{robot.describe_action()} (set [embodiment] action_space = \"joint_pos\")")
    out = {}
    for label, role in zip(joint_parts, roles, strict=True):
        prefix = label[: -len("joint_pos")]
        out[role] = (label, f"{prefix}gripper" if f"{prefix}gripper" in layout else None)
    return {r: out[r] for r in pair_roles}


def _step_towards(cmd: np.ndarray, goal: np.ndarray, max_delta: float) -> np.ndarray:
    return cmd + np.clip(goal - cmd, -max_delta, max_delta)


class LeaderFollower:
    """Controller (rio.loop.control_loop): align each follower to its leader, then mirror it."""

    name = "leader-follower"

    def __init__(self, pairs: list[Pair], *, align_speed: float = 0.5, align_tolerance: float = 0.05):
        self.pairs, self.align_speed, self.align_tolerance = pairs, float(align_speed), float(align_tolerance)

    @classmethod
    def connect(cls, session: Any, *, align_speed: float = 0.5, align_tolerance: float = 0.05) -> LeaderFollower:
        """Connect the station's leaders (`session`: rio.workflows.run.Session) and pair them with its arms."""
        st, robot = session.station, session.env.robot
        roles = find_pairs(st)
        labels = _labels(robot, [a for _, a, _ in roles])
        pairs = []
        for leader_role, arm_role, gripper_role in roles:
            leader = session.stack.enter_context(session.clients[leader_role]())
            s = leader.get_state()
            if "joint_pos" not in s:
                raise RioError(f"teleop device '{leader_role}' ({st.components[leader_role].driver}) publishes no "
                               "joint_pos: leader-follower needs a leader arm")
            n = int(robot.clients[arm_role].num_joints())
            if np.asarray(s["joint_pos"]).size != n:
                raise RioError(f"leader '{leader_role}' has {np.asarray(s['joint_pos']).size} joints, "
                               f"follower '{arm_role}' has {n}")
            label, glabel = labels[arm_role]
            pairs.append(Pair(leader_role, arm_role, leader, label, glabel if gripper_role else None))
        return cls(pairs, align_speed=align_speed, align_tolerance=align_tolerance)

    def reset(self, loop: Any) -> None:
        robot = loop.env.robot
        self.dt, self.say = loop.dt, loop.say
        for p in self.pairs:
            p.aligned, p.t_aligned = False, None  # every run aligns first (the follower may have gone home)
            p.q_cmd = np.asarray(robot.clients[p.arm_role].get_state()["joint_pos"], dtype=np.float64).copy()
            p.start_error = float(np.max(np.abs(np.asarray(p.leader.get_state()["joint_pos"]) - p.q_cmd)))
            if p.gripper_label:
                g = robot.clients["gripper" + p.arm_role[3:]]
                p.max_width = float(g.max_width())
                p.grip_cmd = float(g.get_state()["width"]) / p.max_width if p.max_width > 0 else 0.0
        loop.say(f"aligning {len(self.pairs)} follower(s) to their leader(s) at {self.align_speed:g} rad/s, then "
                 "mirroring " + (f"for {loop.duration:g} s" if loop.duration else "until Ctrl+C"))

    def step(self, tick: Any) -> np.ndarray:
        leaders = {p.leader_role: p.leader.get_state() for p in self.pairs}
        parts: dict[str, Any] = {}
        max_step = self.align_speed * self.dt
        for p in self.pairs:
            s = leaders[p.leader_role]
            q_lead, g_lead = np.asarray(s["joint_pos"], dtype=np.float64), float(s["gripper"])
            p.q_lead_last = q_lead
            if p.aligned:
                p.q_cmd, p.grip_cmd = q_lead.copy(), g_lead
            else:
                p.q_cmd = _step_towards(p.q_cmd, q_lead, max_step)
                p.grip_cmd = float(_step_towards(np.array([p.grip_cmd]), np.array([g_lead]), max_step)[0])
                if np.max(np.abs(q_lead - p.q_cmd)) < self.align_tolerance:
                    p.aligned, p.t_aligned = True, tick.t - tick.t0
                    self.say(f"{p.arm_role} aligned with {p.leader_role} after {p.t_aligned:.2f} s: mirroring")
            parts[p.arm_label] = p.q_cmd
            if p.gripper_label:
                parts[p.gripper_label] = [p.grip_cmd * p.max_width]
        if BASE_TWIST in dict(tick.env.robot.action_parts()):  # a mobile manipulator: the leader drives the arm,
            parts[BASE_TWIST] = np.zeros(3)                    # the base stands still
        tick.info.update(pairs=self.pairs, leaders=leaders)
        return tick.env.robot.build_action(**parts)

    def done(self) -> str | None:
        return None

    def finish(self, summary: Any) -> None:
        pairs = []
        for p in self.pairs:
            q_l = np.asarray(p.leader.get_state()["joint_pos"] if p.q_lead_last is None else p.q_lead_last)
            arm = next((a for a in summary.arms if a.role == p.arm_role), None)
            q_f = None if arm is None else arm.final_q
            final = float(np.max(np.abs(q_f - q_l))) if q_f is not None and q_f.shape == q_l.shape else float("nan")
            pairs.append({"arm": p.arm_role, "leader": p.leader_role, "start_error": p.start_error,
                          "align_s": p.t_aligned, "final_error": final})
            aligned = f"aligned after {p.t_aligned:.2f} s" if p.t_aligned is not None else "never aligned"
            summary.lines.append(f"{p.arm_role} <- {p.leader_role}: started {p.start_error:.3f} rad away, {aligned}, "
                                 f"final error to the leader {final:.3f} rad (max over joints)")
        summary.details["pairs"] = pairs
