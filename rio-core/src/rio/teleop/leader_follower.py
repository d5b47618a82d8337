"""Leader-follower teleop: each follower arm mirrors the joint angles of its leader arm.

Written against `Env` and node clients only (no SO-100 specifics), so it drives any station whose
teleop device(s) publish `joint_pos` (a leader arm) and whose arms take joint actions: one pair
(`teleop` -> `arm` [+ `gripper`]) or ALOHA-style two (`teleop2` -> `arm2` [+ `gripper2`]).

Start-up alignment: a follower is rarely where its leader is when the run starts, and mirroring at
once would snap it across. So each arm first moves towards its leader at `align_speed` (rad/s; the
jaw at `align_speed` of its range per second), chasing the leader if it moves, until every joint is
within `align_tolerance`; from then on it mirrors the leader each cycle. Loop timing is the RIO
paper's: sample mid-cycle, `env.step` with the target one cycle after this one ends.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import clock
from ..errors import RioError

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


@dataclass
class LeaderFollowerTick:
    t: float
    it: int
    step: Any
    pairs: list[Pair]
    leaders: dict[str, dict]
    env: Any = None


@dataclass
class LeaderFollowerSummary:
    station: str
    reason: str = ""
    seconds: float = 0.0
    ticks: int = 0
    rate_hz: float = 0.0
    late_ticks: int = 0
    arms: list[dict] = field(default_factory=list)

    def format(self) -> str:
        hz = self.ticks / self.seconds if self.seconds > 0 else 0.0
        lines = [f"leader-follower on '{self.station}': {self.reason}",
                 f"  {self.seconds:.1f} s, {self.ticks} steps at {hz:.1f} Hz (target {self.rate_hz:g} Hz), "
                 f"{self.late_ticks} late"]
        for a in self.arms:
            aligned = f"aligned after {a['align_s']:.2f} s" if a["align_s"] is not None else "never aligned"
            lines.append(f"  {a['arm']} <- {a['leader']}: started {a['start_error']:.3f} rad away, {aligned}, "
                         f"final error {a['final_error']:.3f} rad (max over joints)")
        return "\n".join(lines)


def find_pairs(station: Any) -> list[tuple[str, str, str | None]]:
    """(leader role, arm role, gripper role or None) of each leader-follower pair of a station."""
    roles = station.roles()
    pairs = [(t, a, g if g in roles else None) for t, a, g in PAIRS if t in roles and a in roles]
    if not pairs:
        raise RioError(f"station '{station.name}' has no leader-follower pair: it needs a `teleop` leader arm and "
                       f"an `arm` (and `teleop2` + `arm2` for two); roles: {sorted(roles)}")
    return pairs


def _labels(robot: Any, arm_roles: list[str]) -> dict[str, tuple[str, str | None]]:
    layout = dict(robot.action_parts())
    joint_parts = [label for label in layout if label.endswith("joint_pos")]
    if len(joint_parts) != len([r for r in ("arm", "arm2") if r in robot.clients]):
        raise RioError(f"leader-follower needs joint-position actions; embodiment '{robot.name}' takes "
                       f"{robot.describe_action()} (set [embodiment] action_space = \"joint_pos\")")
    out = {}
    for label, role in zip(joint_parts, [r for r in ("arm", "arm2") if r in robot.clients], strict=True):
        prefix = label[: -len("joint_pos")]
        out[role] = (label, f"{prefix}gripper" if f"{prefix}gripper" in layout else None)
    return {r: out[r] for r in arm_roles}


def _step_towards(cmd: np.ndarray, goal: np.ndarray, max_delta: float) -> np.ndarray:
    return cmd + np.clip(goal - cmd, -max_delta, max_delta)


def run(station: Any, *, duration: float | None = None, rate_hz: float | None = None, align_speed: float = 0.5,
        align_tolerance: float = 0.05, middleware: str | None = None, instruction: str | None = None,
        on_step: Callable[[LeaderFollowerTick], None] | None = None, should_stop: Callable[[], bool] | None = None,
        log: Callable[[str], None] | None = print) -> LeaderFollowerSummary:
    """Run leader-follower teleop on `station` (name, .toml path or `Station`) until `duration` s,
    `should_stop()`, or Ctrl+C. Returns a summary (alignment time and final error of each arm)."""
    from ..manager import ServerManager
    from ..station.build import make_station
    from ..station.load import load_station

    say = log or (lambda _m: None)
    st = load_station(station)
    roles = find_pairs(st)
    servers, clients, env = make_station(st, middleware=middleware)
    if env is None:
        raise RioError(f"station '{st.name}' has no arm to drive")
    freq = float(rate_hz or st.rate_hz)
    dt = 1.0 / freq
    summary = LeaderFollowerSummary(st.name, rate_hz=freq)
    say(f"starting station '{st.name}' ({len(servers)} nodes over {clients[roles[0][0]].mw.name}) ...")
    with ServerManager(servers, station=st.name), contextlib.ExitStack() as stack:
        stack.enter_context(env)
        env.instruction = instruction
        robot = env.robot
        assert robot is not None  # connected by entering env
        labels = _labels(robot, [a for _, a, _ in roles])
        pairs = []
        for leader_role, arm_role, gripper_role in roles:
            leader = stack.enter_context(clients[leader_role]())
            s = leader.get_state()
            if "joint_pos" not in s:
                raise RioError(f"teleop device '{leader_role}' ({st.components[leader_role].driver}) publishes no "
                               "joint_pos: leader-follower needs a leader arm")
            arm = robot.clients[arm_role]
            n = int(arm.num_joints())
            if np.asarray(s["joint_pos"]).size != n:
                raise RioError(f"leader '{leader_role}' has {np.asarray(s['joint_pos']).size} joints, "
                               f"follower '{arm_role}' has {n}")
            label, glabel = labels[arm_role]
            p = Pair(leader_role, arm_role, leader, label, glabel if gripper_role else None)
            p.q_cmd = np.asarray(arm.get_state()["joint_pos"], dtype=np.float64).copy()
            p.start_error = float(np.max(np.abs(np.asarray(s["joint_pos"]) - p.q_cmd)))
            if p.gripper_label and gripper_role:
                g = robot.clients[gripper_role]
                p.max_width = float(g.max_width())
                p.grip_cmd = float(g.get_state()["position"]) / p.max_width if p.max_width > 0 else 0.0
            pairs.append(p)
        say(f"aligning {len(pairs)} follower(s) to their leader(s) at {align_speed:g} rad/s, then mirroring "
            + (f"for {duration:g} s" if duration else "until Ctrl+C"))
        t_start = clock.now()
        env.set_start_time(t_start)
        it = 0
        summary.reason = "duration reached"
        try:
            while True:
                t_cycle_end = t_start + (it + 1) * dt
                t_sample = t_cycle_end - dt / 2
                clock.precise_wait(t_sample)
                leaders = {p.leader_role: p.leader.get_state() for p in pairs}
                parts: dict[str, Any] = {}
                for p in pairs:
                    s = leaders[p.leader_role]
                    q_lead = np.asarray(s["joint_pos"], dtype=np.float64)
                    g_lead = float(s["gripper"])
                    if p.aligned:
                        p.q_cmd, p.grip_cmd = q_lead.copy(), g_lead
                    else:
                        p.q_cmd = _step_towards(p.q_cmd, q_lead, align_speed * dt)
                        p.grip_cmd = float(_step_towards(np.array([p.grip_cmd]), np.array([g_lead]),
                                                         align_speed * dt)[0])
                        if np.max(np.abs(q_lead - p.q_cmd)) < align_tolerance:
                            p.aligned, p.t_aligned = True, t_sample - t_start
                            say(f"{p.arm_role} aligned with {p.leader_role} after {p.t_aligned:.2f} s: mirroring")
                    parts[p.arm_label] = p.q_cmd
                    if p.gripper_label:
                        parts[p.gripper_label] = [p.grip_cmd * p.max_width]
                step = env.step(robot.build_action(**parts), t_cmd_target=t_cycle_end + dt)
                if on_step is not None:
                    on_step(LeaderFollowerTick(t_sample, it, step, pairs, leaders, env))
                it += 1
                summary.ticks += 1
                late = clock.now() - t_cycle_end
                if late > 0:
                    summary.late_ticks += 1
                    if late > dt:  # fell a whole cycle behind: re-anchor instead of bursting
                        it = int((clock.now() - t_start) / dt)
                clock.precise_wait(t_cycle_end)
                if duration is not None and clock.now() - t_start >= duration:
                    break
                if should_stop is not None and should_stop():
                    summary.reason = "stopped"
                    break
        except KeyboardInterrupt:
            summary.reason = "interrupted (Ctrl+C)"
        summary.seconds = clock.now() - t_start
        clock.precise_wait(clock.now() + 3 * dt)  # let the last commands land before measuring
        for p in pairs:
            q_f = np.asarray(robot.clients[p.arm_role].get_state()["joint_pos"])
            q_l = np.asarray(p.leader.get_state()["joint_pos"])
            summary.arms.append({"arm": p.arm_role, "leader": p.leader_role, "start_error": p.start_error,
                                 "align_s": p.t_aligned, "final_error": float(np.max(np.abs(q_f - q_l)))})
    return summary
