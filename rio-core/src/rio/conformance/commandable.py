"""Kits of the kinds that take targets through their commander: arms, hands, humanoids (joints) and
grippers. See `rio.conformance.drivers`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import pytest

from rio import clock
from rio.conformance.driver_base import (
    BOOL,
    CLIP,
    DISABLED,
    ENABLE,
    FLOAT,
    FOLLOWS,
    INT,
    REQUESTS,
    SI,
    STEP,
    WATCHDOG,
    WATCHDOG_DAMPS,
    DriverConformance,
    KeySpec,
    far_target,
    quat_ok,
)
from rio.conformance.driving import Loop, expect, fmt, violated
from rio.errors import InvalidRequest
from rio.interfaces import JOINT, ArmNode, GripperNode, HandNode, HumanoidNode, JointNode
from rio.interfaces.damping import STALE_COMMANDS
from rio.runtime.node import Node
from rio.testing import lifecycle, wait_until


class _CommandableConformance(DriverConformance):
    """Cases of the kinds that take targets through the kind's commander (joints, gripper)."""

    goal_hook: ClassVar[str] = "write_joints"
    unit: ClassVar[str] = "rad"
    what: ClassVar[str] = "joint"
    #: How far (in `unit`) the measured position may differ from the goal through the emulator's own
    #: dynamics (lag, quantization, settling).
    tracking_tol: ClassVar[float] = 0.03
    #: How far beyond the upper limit the clipping case aims.
    beyond: ClassVar[float] = 1.0
    #: Distance of the watchdog and enable cases' targets (within the limits).
    move_distance: ClassVar[float] = 1.0
    #: Time the emulator may take to settle on a goal (s).
    settle_s: ClassVar[float] = 0.3
    #: What the watchdog case expects of a silent stream: "hold" (the kind's stiff hold), "damp" (the
    #: driver's stale_commands fault, `rio.interfaces.damping`), or None: ask the driver (`damps_on_stale`).
    on_stale: ClassVar[str | None] = None

    # -- kind accessors ------------------------------------------------------------------------------
    def measure(self, sample: Mapping[str, Any]) -> np.ndarray:
        raise NotImplementedError

    def limits(self, node: Any) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def max_step(self, node: Any) -> float:
        raise NotImplementedError

    def command(self, node: Any, target: np.ndarray, t_cmd_target: float) -> None:
        """Send a target the way the runtime does (`handle_request`)."""
        raise NotImplementedError

    def goal_of(self, *args: Any, **kwargs: Any) -> Any:
        return args[0]

    def loop(self, node: Node) -> Loop:
        return Loop(node, self.goal_hook, self.goal_of)

    def _start(self, node: Any) -> tuple[Loop, np.ndarray]:
        if not node.enabled:
            node.enable()
        loop = self.loop(node)
        last = loop.run(cycles=3)
        if last is None:
            violated(self.kind, SI, f"no sample in {loop.ticks} ticks after start")
        return loop, self.measure(last)

    def _label(self, i: int) -> str:
        return f"{self.what} {i}" if self.what == "joint" else self.what

    def damps_on_stale(self, node: Any) -> bool:
        """Whether the node under test damps a silent stream instead of holding it (`on_stale`, else what
        the node's damping guard says: `node.safety.damps_on_stale`, `rio.interfaces.DampingGuard`)."""
        if self.on_stale is not None:
            return self.on_stale == "damp"
        safety = getattr(node, "safety", None)
        return bool(getattr(safety, "damps_on_stale", False))

    def request_keys(self, node: Node) -> KeySpec:
        return {"t_cmd_target": ((), FLOAT)}

    # -- cases ---------------------------------------------------------------------------------------
    def test_targets_beyond_the_limit_end_at_the_limit(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop, q0 = self._start(node)
            lower, upper = self.limits(node)
            sides = [("upper", j) for j in np.flatnonzero(np.isfinite(upper))[:1]]
            if self.what != "joint":
                sides.append(("lower", 0))
            if not sides:
                pytest.skip(f"{self.name} enforces no finite upper limit (joint_limits() is unbounded); set "
                            "`joint_limits` in config to test clipping")
            for side, j in sides:
                limit = float(upper[j] if side == "upper" else lower[j])
                beyond = limit + (self.beyond if side == "upper" else -self.beyond)
                q_now = self.measure(loop.last)
                target = q_now.copy()
                target[j] = beyond
                n0, s0 = len(loop.writes), len(loop.samples)
                self.command(node, target, clock.now())
                past = (lambda x, limit=limit: x > limit + 1e-9) if side == "upper" else \
                    (lambda x, limit=limit: x < limit - 1e-9)

                def check_goals(n0: int = n0, j: int = j, past=past, limit: float = limit, side: str = side,
                                beyond: float = beyond) -> list[float]:
                    goals = [g[j] for g in loop.goals[n0:]]
                    bad = [g for g in goals if past(g)]
                    expect(not bad, self.kind, CLIP, lambda: f"{self._label(j)}: goal {bad[0]:.4f} {self.unit} "
                           f"written beyond the {side} limit {limit:.4f} (target {beyond:.4f})")
                    return goals

                steps = math.ceil(abs(limit - q_now[j]) / self.max_step(node)) + 3
                loop.run(cycles=steps)
                check_goals()
                loop.run(until=lambda s, j=j, limit=limit: abs(self.measure(s)[j] - limit) <= self.tracking_tol,
                         timeout=5.0)
                loop.run(seconds=self.settle_s)
                goals = check_goals()
                measured = [self.measure(s)[j] for s in loop.samples[s0:]]
                expect(goals and abs(goals[-1] - limit) < 1e-9, self.kind, CLIP,
                       f"{self._label(j)}: the goal ended at {goals[-1] if goals else None} {self.unit}, not at the "
                       f"{side} limit {limit:.4f} (target {beyond:.4f})")
                far = [m for m in measured if past(m) and abs(m - limit) > self.tracking_tol]
                expect(not far, self.kind, CLIP, f"{self._label(j)}: measured {far[0] if far else 0:.4f} {self.unit}, "
                       f"beyond the {side} limit {limit:.4f} by more than tracking_tol {self.tracking_tol}")
                expect(abs(measured[-1] - limit) <= self.tracking_tol, self.kind, CLIP,
                       f"{self._label(j)}: measured {measured[-1]:.4f} {self.unit} at the end, not at the {side} limit "
                       f"{limit:.4f} (tracking_tol {self.tracking_tol})")

    #: Fields the step case adds to the driver's: it measures the kind's step limit alone (an arm's tool speed
    #: limit, `max_tool_speed_m_s`, would slow a far joint move below one step per cycle).
    step_case_fields: ClassVar[dict[str, Any]] = {}

    def test_a_far_target_moves_at_most_max_step_per_cycle(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, {**driver_fields, **self.step_case_fields})
        with lifecycle(node):
            loop, q0 = self._start(node)
            step = self.max_step(node)
            lower, upper = self.limits(node)
            target = far_target(q0, lower, upper, 5 * step)
            if np.abs(target - q0).max() <= 1.01 * step:
                pytest.skip(f"the limits leave no room for a move of several steps of {step} {self.unit}")
            before = loop.goals[-1] if loop.goals else q0
            n0, s0 = len(loop.writes), len(loop.samples)
            self.command(node, target, clock.now())  # arriving now: only the step limit slows it
            loop.run(cycles=8)
            goals = [before] + loop.goals[n0:]
            expect(len(goals) > 1, self.kind, STEP, "nothing was written to the driver in 8 cycles while enabled")
            for k in range(1, len(goals)):
                d = np.abs(goals[k] - goals[k - 1])
                j = int(np.argmax(d))
                expect(d[j] <= step + 1e-9, self.kind, STEP,
                       f"{self._label(j)}: the goal written moved {d[j]:.4f} {self.unit} in one cycle (from "
                       f"{goals[k - 1][j]:.4f} to {goals[k][j]:.4f}, target {target[j]:.4f}); max_step is {step}")
            moved = np.abs(goals[-1] - before).max()
            expect(moved >= min(step, np.abs(target - before).max()) * 0.99, self.kind, STEP,
                   f"the goal moved only {moved:.4f} {self.unit} toward a target {fmt(target)} in 8 cycles")
            for k, s in enumerate(loop.samples[s0:], start=1):
                d = np.abs(self.measure(s) - q0)
                j = int(np.argmax(d))
                expect(d[j] <= k * step + self.tracking_tol, self.kind, STEP,
                       f"{self._label(j)}: measured {d[j]:.4f} {self.unit} from the start after {k} cycles, more "
                       f"than {k} x max_step {step} + tracking_tol {self.tracking_tol}")

    def test_a_silent_stream_is_held_by_the_watchdog(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop, q0 = self._start(node)
            watchdog = float(node.config.watchdog_s)
            lower, upper = self.limits(node)
            target = far_target(q0, lower, upper, self.move_distance)
            j = int(np.argmax(np.abs(target - q0)))
            now = clock.now()
            for frac, dt in ((0.01, 0.05), (0.02, 0.1)):  # a stream: commands well within watchdog_s ...
                self.command(node, q0 + frac * (target - q0), now + dt)
            self.command(node, target, now + 20.0)  # ... whose last target is far ahead, then silence
            t_last = clock.now()
            s = loop.tick()
            if s is not None and clock.now() - t_last < 0.5 * watchdog:
                expect(not s["holding"], self.kind, WATCHDOG, "`holding` was true right after a fresh command")
            if self.damps_on_stale(node):
                self._check_damped(node, loop, t_last, q0, target, j)
                return
            loop.run(until=lambda s: clock.now() - t_last > watchdog + 0.1, timeout=watchdog + 5.0)
            loop.run(seconds=self.settle_s)
            s = loop.last
            expect(s["holding"], self.kind, WATCHDOG,
                   f"`holding` is false {clock.now() - t_last:.2f} s after the last command (watchdog_s {watchdog})")
            n0, s0 = len(loop.writes), len(loop.samples)
            held = loop.goals[-1] if loop.goals else None
            loop.run(seconds=0.25)
            loop.run(cycles=5)
            window = loop.goals[n0:]
            expect(held is not None and window, self.kind, WATCHDOG, "no goal was written while enabled")
            for g in window:
                d = np.abs(g - held)
                k = int(np.argmax(d))
                expect(d[k] < 1e-9, self.kind, WATCHDOG,
                       f"{self._label(k)}: the goal written kept moving {clock.now() - t_last:.2f} s after the "
                       f"stream stopped (from {held[k]:.4f} to {g[k]:.4f} {self.unit}, target {target[k]:.4f})")
            expect(abs(target[j] - held[j]) >= 0.5 * abs(target[j] - q0[j]), self.kind, WATCHDOG,
                   f"{self._label(j)}: the goal went to {held[j]:.4f} {self.unit}, most of the way to a target "
                   f"{target[j]:.4f} due in 20 s, instead of stopping {watchdog} s after the stream went silent")
            measured = np.array([self.measure(s) for s in loop.samples[s0:]])
            spread = measured.max(axis=0) - measured.min(axis=0)
            k = int(np.argmax(spread))
            expect(spread[k] <= self.tracking_tol, self.kind, WATCHDOG,
                   f"{self._label(k)}: measured moved {spread[k]:.4f} {self.unit} while the goal was held "
                   f"(tracking_tol {self.tracking_tol})")

    def _check_damped(self, node: Any, loop: Loop, t_last: float, q0: np.ndarray, target: np.ndarray,
                      j: int) -> None:
        """The watchdog case of a driver that damps: it stops itself (disabled, its stale_commands fault),
        never before watchdog_s, is driven no more, refuses commands, and clear_faults() holds where it is."""
        watchdog = float(node.config.watchdog_s)
        s = loop.run(until=lambda s: not s["enabled"], timeout=watchdog + 5.0)
        waited = clock.now() - t_last
        expect(s is not None and not s["enabled"], self.kind, WATCHDOG_DAMPS,
               f"still enabled {waited:.2f} s after the last command (watchdog_s {watchdog})")
        expect(waited >= watchdog, self.kind, WATCHDOG_DAMPS,
               f"stopped {waited:.2f} s after the last command, before watchdog_s {watchdog} had passed")
        held = loop.goals[-1] if loop.goals else q0
        expect(abs(target[j] - held[j]) >= 0.5 * abs(target[j] - q0[j]), self.kind, WATCHDOG_DAMPS,
               f"{self._label(j)}: the goal went to {held[j]:.4f} {self.unit}, most of the way to a target "
               f"{target[j]:.4f} due in 20 s, instead of stopping {watchdog} s after the stream went silent")
        s = loop.run(cycles=2)  # the sample of the cycle that faulted may predate the fault
        if s is None:
            violated(self.kind, WATCHDOG_DAMPS, f"no sample in {loop.ticks} ticks after the stop")
        expect(s.get("fault_code", STALE_COMMANDS) == STALE_COMMANDS and s["holding"], self.kind, WATCHDOG_DAMPS,
               f"after the stop a sample has fault_code={s.get('fault_code')}, holding={s['holding']} (expected "
               f"{STALE_COMMANDS}, stale_commands, and holding)")
        n0 = len(loop.writes)
        s = loop.run(cycles=5) or s
        expect(len(loop.writes) == n0, self.kind, WATCHDOG_DAMPS,
               f"{len(loop.writes) - n0} goals written to the driver in 5 cycles after it damped")
        self._expect_refused(node, target, WATCHDOG_DAMPS, "a command after the stop was accepted (it must be "
                                                           "refused, naming the fault, until clear_faults())")
        q_off = self.measure(s)
        expect(getattr(node, "faults", None) is not None, self.kind, WATCHDOG_DAMPS,
               "the node holds no faults (node.faults is None): a driver that damps holds its stale_commands "
               "fault (rio.interfaces.FaultHolder)")
        node.clear_faults()
        n0 = len(loop.writes)
        s = loop.run(cycles=5)
        goals = loop.goals[n0:]
        expect(goals and s is not None and s["enabled"], self.kind, WATCHDOG_DAMPS,
               f"clear_faults() did not enable the node again ({len(goals)} goals written in 5 cycles)")
        d = np.abs(goals[0] - q_off)
        k = int(np.argmax(d))
        expect(d[k] <= self.tracking_tol, self.kind, WATCHDOG_DAMPS,
               f"{self._label(k)}: after clear_faults() the goal written was {goals[0][k]:.4f} {self.unit}; the "
               f"device was at {q_off[k]:.4f} (tracking_tol {self.tracking_tol})")

    def _expect_refused(self, node: Any, target: np.ndarray, rule: str, accepted: str) -> None:
        """A command now must raise InvalidRequest naming the node; `accepted` says why it must not pass."""
        try:
            self.command(node, target, clock.now() + 1.0)
        except InvalidRequest as e:
            expect(e.node == node.name, self.kind, rule, f"the InvalidRequest names node '{e.node}', not "
                                                         f"'{node.name}': {e}")
        else:
            violated(self.kind, rule, accepted)

    def test_disabled_refuses_commands_and_enable_holds_the_pose(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop, q0 = self._start(node)
            lower, upper = self.limits(node)
            target = far_target(q0, lower, upper, self.move_distance)
            self.command(node, target, clock.now() + 2.0)
            loop.run(cycles=10)  # under way
            node.disable()
            self._expect_refused(node, target, DISABLED, "a command to the disabled device was accepted (it must "
                                                         "raise InvalidRequest: it would be replayed on enable)")
            n0, s0 = len(loop.writes), len(loop.samples)
            loop.run(cycles=5)
            expect(len(loop.writes) == n0, self.kind, DISABLED,
                   f"{len(loop.writes) - n0} goals written to the driver in 5 cycles while disabled")
            for s in loop.samples[s0:]:
                expect(not s["enabled"] and s["holding"], self.kind, DISABLED,
                       f"a sample while disabled has enabled={s['enabled']}, holding={s['holding']}")
            q_off = self.measure(loop.last)
            node.enable()
            n0, s0 = len(loop.writes), len(loop.samples)
            loop.run(seconds=self.settle_s)
            loop.run(cycles=5)
            goals = loop.goals[n0:]
            expect(goals, self.kind, ENABLE, "nothing written to the driver after enable()")
            for g in goals:
                d = np.abs(g - q_off)
                k = int(np.argmax(d))
                expect(d[k] <= self.tracking_tol, self.kind, ENABLE,
                       f"{self._label(k)}: after enable() the goal written was {g[k]:.4f} {self.unit}; the pose "
                       f"at enable was {q_off[k]:.4f} (the target before disable was {target[k]:.4f})")
            measured = np.array([self.measure(s) for s in loop.samples[s0:]])
            d = np.abs(measured - q_off).max(axis=0)
            k = int(np.argmax(d))
            expect(d[k] <= self.tracking_tol, self.kind, ENABLE,
                   f"{self._label(k)}: measured moved {d[k]:.4f} {self.unit} after enable() with no new command")
            for s in loop.samples[s0:]:
                expect(s["enabled"], self.kind, ENABLE, "a sample after enable() has enabled=False")

    def test_bad_requests_are_rejected_by_name(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        example = {k: np.asarray(v) for k, v in node.example_request.items()}
        with self._served(driver_under_test, driver_fields) as c:
            t0 = float(self._first_sample(c)["timestamp"])
            for field, v in example.items():
                bad = []
                if v.dtype.kind in "fc":
                    bad.append(("NaN", np.full(v.shape, np.nan)))
                bad.append(("a wrong shape", np.zeros(v.shape[:-1] + (v.shape[-1] + 1,) if v.shape else (2,),
                                                      v.dtype)))
                for label, value in bad:
                    try:
                        c.send_request({**example, field: value})
                    except InvalidRequest as e:
                        expect(e.node == self.name and e.field == field, self.kind, REQUESTS,
                               f"a request with {label} in '{field}' was rejected as node '{e.node}', field "
                               f"'{e.field}': {e}")
                    else:
                        violated(self.kind, REQUESTS, f"a request with {label} in '{field}' was accepted")
            expect(wait_until(lambda: float(c.get_state()["timestamp"]) > t0, timeout=5.0), self.kind, REQUESTS,
                   "the node stopped publishing after rejected requests")


class _JointConformance(_CommandableConformance):
    node_base: ClassVar[type[Node]] = JointNode
    read_hook: ClassVar[str] = "read_joints"
    #: Largest plausible |joint position| and |limit| (rad): more looks like degrees. Raise it for
    #: multi-turn joints.
    max_joint_abs: ClassVar[float] = 2 * math.pi

    def measure(self, sample: Mapping[str, Any]) -> np.ndarray:
        return np.asarray(sample["joint_pos"], dtype=np.float64).reshape(-1)

    def limits(self, node: Any) -> tuple[np.ndarray, np.ndarray]:
        lower, upper = node.joint_limits()
        return np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)

    def max_step(self, node: Any) -> float:
        return float(node.config.max_step_rad)

    def command(self, node: Any, target: np.ndarray, t_cmd_target: float) -> None:
        node.handle_request({**node.example_request, "joint_pos": np.asarray(target, dtype=np.float64),
                             "t_cmd_target": float(t_cmd_target)})

    def kind_keys(self, node: Any) -> KeySpec:
        n = node.dof
        return {"joint_pos": ((n,), FLOAT), "joint_vel": ((n,), FLOAT), "enabled": ((), BOOL),
                "holding": ((), BOOL)}

    def request_keys(self, node: Any) -> KeySpec:
        return {"joint_pos": ((node.dof,), FLOAT), "t_cmd_target": ((), FLOAT)}

    def measured_keys(self, node: Node) -> tuple[str, ...]:
        return ("joint_pos",)

    def check_units(self, node: Any, sample: Mapping[str, Any], i: int) -> None:
        q = self.measure(sample)
        lower, upper = self.limits(node)
        big = self.max_joint_abs + 1e-6
        expect(np.all(np.abs(q) <= big), self.kind, SI,
               f"sample {i}: joint_pos {fmt(q)} beyond +-{self.max_joint_abs:.3f} rad: degrees, or encoder steps?")
        for name, lim in (("lower", lower), ("upper", upper)):
            finite = lim[np.isfinite(lim)]
            expect(np.all(np.abs(finite) <= big), self.kind, SI,
                   f"joint_limits() {name} {fmt(lim)} beyond +-{self.max_joint_abs:.3f} rad: degrees?")
        tol = self.tracking_tol
        out = np.flatnonzero((q < lower - tol) | (q > upper + tol))
        expect(out.size == 0, self.kind, SI, lambda: f"sample {i}: joint {out[0]} at {q[out[0]]:.4f} rad, outside "
               f"its enforced limits [{lower[out[0]]:.4f}, {upper[out[0]]:.4f}] (tolerance {tol})")
        if node.config.enable_on_open:
            expect(bool(sample["enabled"]), self.kind, SI, f"sample {i}: enabled is false (enable_on_open is set)")


class ArmConformance(_JointConformance):
    """The arm contract (`rio.interfaces.ArmNode`), in joint space."""

    kind: ClassVar[str] = "arm"
    node_base: ClassVar[type[Node]] = ArmNode
    #: Largest plausible distance of the end effector from the base (m).
    max_reach_m: ClassVar[float] = 5.0
    step_case_fields: ClassVar[dict[str, Any]] = {"max_tool_speed_m_s": 1e6}

    def kind_keys(self, node: Any) -> KeySpec:
        return {**super().kind_keys(node), "eef_pose": ((7,), FLOAT)}

    def request_keys(self, node: Any) -> KeySpec:
        return {**super().request_keys(node), "mode": ((), INT), "eef_pose": ((7,), FLOAT)}

    def command(self, node: Any, target: np.ndarray, t_cmd_target: float) -> None:
        node.handle_request({**node.example_request, "mode": JOINT, "joint_pos": np.asarray(target, dtype=np.float64),
                             "t_cmd_target": float(t_cmd_target)})

    def check_units(self, node: Any, sample: Mapping[str, Any], i: int) -> None:
        super().check_units(node, sample, i)
        pose = np.asarray(sample["eef_pose"], dtype=np.float64)
        if np.isnan(pose).all():
            return
        expect(np.isfinite(pose).all(), self.kind, SI,
               f"sample {i}: eef_pose {fmt(pose)} is partly NaN: publish a whole pose, or all NaN when unmeasured")
        expect(quat_ok(pose[3:]), self.kind, SI,
               f"sample {i}: eef_pose quaternion {fmt(pose[3:])} (norm {np.linalg.norm(pose[3:]):.4f}) is not a unit "
               "quaternion [qw, qx, qy, qz]")
        expect(np.linalg.norm(pose[:3]) <= self.max_reach_m, self.kind, SI,
               f"sample {i}: eef_pose position {fmt(pose[:3])} is more than {self.max_reach_m} m from the base: "
               "millimeters?")

    def test_eef_pose_follows_the_joints(self, driver_under_test, driver_fields):
        """A finite eef_pose is measured or computed from the joints; a made-up constant fails."""
        from rio.control import pose_error

        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop, q0 = self._start(node)
            pose0 = np.asarray(loop.last["eef_pose"], dtype=np.float64)
            if np.isnan(pose0).all():
                return  # not measured and no model: NaN is the contract
            lower, upper = self.limits(node)
            up, down = upper - q0, q0 - lower
            delta = np.where(up >= 0.25, 0.2, np.where(down >= 0.25, -0.2, 0.0))
            target = q0 + delta
            self.command(node, target, clock.now() + 0.3)
            loop.run(until=lambda s: np.abs(self.measure(s) - target).max() <= self.tracking_tol, timeout=5.0)
            loop.run(seconds=0.1)
            q1 = self.measure(loop.last)
            expect(np.abs(q1 - q0).max() >= 0.1, self.kind, FOLLOWS,
                   f"the joints did not follow a joint target: {fmt(q0)} -> {fmt(q1)} (target {fmt(target)})")
            pose1 = np.asarray(loop.last["eef_pose"], dtype=np.float64)
            expect(np.isfinite(pose1).all(), self.kind, FOLLOWS,
                   f"eef_pose went from {fmt(pose0)} to {fmt(pose1)} after a joint move")
            dp, da = pose_error(pose0, pose1)
            expect(dp > 1e-4 or da > 1e-4, self.kind, FOLLOWS,
                   f"eef_pose stayed at {fmt(pose1)} while the joints moved from {fmt(q0)} to {fmt(q1)}: publish the "
                   "measured pose, or let the kind compute it from robot_description(), or NaN; never a constant")


class HandConformance(_JointConformance):
    """The hand contract (`rio.interfaces.HandNode`)."""

    kind: ClassVar[str] = "hand"
    node_base: ClassVar[type[Node]] = HandNode


class HumanoidConformance(_JointConformance):
    """The humanoid contract (`rio.interfaces.HumanoidNode`): joints plus the base IMU."""

    kind: ClassVar[str] = "humanoid"
    node_base: ClassVar[type[Node]] = HumanoidNode

    def kind_keys(self, node: Any) -> KeySpec:
        return {**super().kind_keys(node), "base_quat": ((4,), FLOAT), "base_ang_vel": ((3,), FLOAT)}

    def check_units(self, node: Any, sample: Mapping[str, Any], i: int) -> None:
        super().check_units(node, sample, i)
        quat = np.asarray(sample["base_quat"], dtype=np.float64)
        expect(np.isnan(quat).all() or quat_ok(quat), self.kind, SI,
               f"sample {i}: base_quat {fmt(quat)} is neither a unit quaternion [qw, qx, qy, qz] nor all NaN")


class GripperConformance(_CommandableConformance):
    """The gripper contract (`rio.interfaces.GripperNode`): opening in meters."""

    kind: ClassVar[str] = "gripper"
    node_base: ClassVar[type[Node]] = GripperNode
    read_hook: ClassVar[str] = "read_width"
    goal_hook: ClassVar[str] = "write_width"
    unit: ClassVar[str] = "m"
    what: ClassVar[str] = "opening"
    tracking_tol: ClassVar[float] = 0.002
    beyond: ClassVar[float] = 0.5
    move_distance: ClassVar[float] = 0.5  # at most 80 % of the room, i.e. most of the width
    #: Largest plausible full opening (m): more looks like millimeters.
    max_width_m: ClassVar[float] = 0.5

    def measure(self, sample: Mapping[str, Any]) -> np.ndarray:
        return np.asarray([sample["width"]], dtype=np.float64)

    def limits(self, node: Any) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(1), np.array([float(node.max_width())])

    def max_step(self, node: Any) -> float:
        return float(node.config.max_step_m)

    def command(self, node: Any, target: np.ndarray, t_cmd_target: float) -> None:
        node.handle_request({"width": float(np.asarray(target).reshape(-1)[0]),
                             "t_cmd_target": float(t_cmd_target), "force": 0.0})

    def goal_of(self, width: float, force: float | None = None, *args: Any, **kwargs: Any) -> Any:
        return [width]

    def kind_keys(self, node: Any) -> KeySpec:
        return {"width": ((), FLOAT), "max_width": ((), FLOAT), "enabled": ((), BOOL), "holding": ((), BOOL)}

    def request_keys(self, node: Any) -> KeySpec:
        return {"width": ((), FLOAT), "t_cmd_target": ((), FLOAT), "force": ((), FLOAT)}

    def measured_keys(self, node: Node) -> tuple[str, ...]:
        return ("width", "max_width")

    def check_units(self, node: Any, sample: Mapping[str, Any], i: int) -> None:
        width = float(sample["max_width"])
        expect(0.0 < width < self.max_width_m, self.kind, SI,
               f"sample {i}: max_width {width} is not a plausible opening in meters (0 < max_width < "
               f"{self.max_width_m})")
        pos, tol = float(sample["width"]), self.tracking_tol
        expect(-tol <= pos <= width + tol, self.kind, SI,
               f"sample {i}: width {pos:.4f} m outside [0, max_width {width}] (tolerance {tol})")


