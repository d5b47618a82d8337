"""The mobile base kit (`BaseConformance`): the contract of `rio.interfaces.BaseNode`, checked on the twists
the kind asks the driver to write (`write_twist`, wrapped on the instance: exact, no physics in between)
and on what the driver measures. See `rio.conformance.drivers`.

    class TestAcmeBase(BaseConformance):
        driver = "acme.base"
        config = {"port": "emulator"}
        tracking_tol = 0.05       # m/s, rad/s: how far the measured twist may lag the written one

What it checks: the kind's keys; SI units (wheel and body speeds finite, the odometry heading in
[-pi, pi]); speed limits (a wild twist is written at the limit, never past it); acceleration limits (the
twist written changes at most `max_*_accel / rate_hz` per cycle); the stop watchdog (a stream of commands
that goes silent is ramped to zero once `watchdog_s` has passed, never before, and the wheels stop);
disable/enable (a disabled base refuses commands and is not driven; enable does not start it moving);
odometry (driving straight ahead moves the pose forward, not sideways, without turning); and that closing
the node stops the base before it lets go.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from rio import clock
from rio.conformance.driver_base import BOOL, DISABLED, ENABLE, FLOAT, SI, DriverConformance, KeySpec
from rio.conformance.driving import Loop, expect, fmt, violated
from rio.errors import InvalidRequest
from rio.interfaces.base import BaseNode
from rio.runtime.node import Node
from rio.testing import lifecycle

SPEED = "speed limits: a twist beyond max_linear_speed / max_angular_speed is written at the limit, never beyond"
ACCEL = "acceleration limits: the twist written changes at most max_*_accel / rate_hz per cycle"
STOPS = "stop watchdog: a stream of twists that goes silent is ramped to zero once watchdog_s has passed"
ODOMETRY = "odometry: driving straight ahead moves odom_pose forward, without turning"
CLOSES = "closing stops the base: the last twist written before the node lets go is zero"


class BaseConformance(DriverConformance):
    kind = "base"
    node_base = BaseNode
    read_hook = "read_wheels"
    #: How far (m/s, rad/s) the measured body twist may differ from the twist written, through the
    #: emulator's own dynamics (motor lag, speed quantization).
    tracking_tol: ClassVar[float] = 0.03
    #: Time the emulator's wheels may take to reach a written speed (s).
    settle_s: ClassVar[float] = 0.3
    #: The test drive's twist, as a fraction of the node's speed limits.
    drive_fraction: ClassVar[float] = 0.5

    # -- kind accessors ------------------------------------------------------------------------------
    def kind_keys(self, node: Node) -> KeySpec:
        n = node.n_wheels  # type: ignore[attr-defined]  # (a BaseNode, typed as the node)
        return {"wheel_pos": ((n,), FLOAT), "wheel_vel": ((n,), FLOAT), "body_twist": ((3,), FLOAT),
                "odom_pose": ((3,), FLOAT), "enabled": ((), BOOL), "holding": ((), BOOL)}

    def request_keys(self, node: Node) -> KeySpec:
        return {"twist": ((3,), FLOAT), "t_cmd_target": ((), FLOAT)}

    def measured_keys(self, node: Node) -> tuple[str, ...]:
        return ("wheel_pos", "wheel_vel", "body_twist", "odom_pose")

    def check_units(self, node: Node, sample: Mapping[str, Any], i: int) -> None:
        theta = float(sample["odom_pose"][2])
        expect(-np.pi - 1e-9 <= theta <= np.pi + 1e-9, self.kind, SI,
               f"sample {i}: odom_pose heading {theta:.4f} rad is outside [-pi, pi]")

    def loop(self, node: Node) -> Loop:
        return Loop(node, "write_twist")

    def command(self, node: Any, twist: Any, t_cmd_target: float) -> None:
        """A twist, the way the runtime delivers it (`handle_request`)."""
        node.handle_request({"twist": np.asarray(twist, dtype=np.float64), "t_cmd_target": float(t_cmd_target)})

    def drive(self, node: Any) -> np.ndarray:
        c = node.config
        return self.drive_fraction * np.array([c.max_linear_speed, 0.0, 0.0])

    def _start(self, node: Any) -> Loop:
        if not node.enabled:
            node.enable()
        loop = self.loop(node)
        if loop.run(cycles=3) is None:
            violated(self.kind, SI, f"no sample in {loop.ticks} ticks after start")
        return loop

    def _stream(self, node: Any, loop: Loop, twist: np.ndarray, cycles: int, seconds: float = 0.0) -> float:
        """Send `twist` every cycle, as a teleop loop or a policy does, for `cycles` cycles and at least
        `seconds`; returns the time the last one was sent at (taken before it was: the node's own clock for it
        is no earlier). Counted in cycles because the limits are per cycle: a loaded machine that runs fewer
        cycles per second must not fail a ramp that simply had fewer cycles."""
        t_end, n, t_sent = clock.now() + seconds, 0, clock.now()
        while n < cycles or clock.now() < t_end:
            t_sent = clock.now()
            self.command(node, twist, t_sent + 1.0 / node.rate_hz)
            loop.tick()
            n += 1
        return t_sent

    def _ramp_cycles(self, node: Any, twist: np.ndarray) -> int:
        """Cycles the acceleration limits take to reach `twist` from rest (and one to spare)."""
        lin_step, ang_step = self._steps(node)
        return int(np.ceil(max(float(np.hypot(twist[0], twist[1])) / lin_step, abs(float(twist[2])) / ang_step))) + 2

    @staticmethod
    def _steps(node: Any) -> tuple[float, float]:
        c = node.config
        return c.max_linear_accel / node.rate_hz, c.max_angular_accel / node.rate_hz

    # -- cases ---------------------------------------------------------------------------------------
    def test_a_twist_beyond_the_speed_limits_is_written_at_the_limit(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop = self._start(node)
            c = node.config
            wild = np.array([10.0 * c.max_linear_speed + 1.0, 0.0, 10.0 * c.max_angular_speed + 1.0])
            lin_step, ang_step = self._steps(node)
            ramp = max(c.max_linear_speed / lin_step, c.max_angular_speed / ang_step)
            n0 = len(loop.writes)
            for _ in range(int(np.ceil(ramp)) + 10):
                self.command(node, wild, clock.now())
                loop.tick()
            goals = loop.goals[n0:]
            expect(goals, self.kind, SPEED, "nothing was written to the driver while enabled")
            for g in goals:
                lin = float(np.hypot(g[0], g[1]))
                expect(lin <= c.max_linear_speed + 1e-9 and abs(g[2]) <= c.max_angular_speed + 1e-9, self.kind,
                       SPEED, f"twist {fmt(g)} written for a command {fmt(wild)}: beyond max_linear_speed "
                              f"{c.max_linear_speed} / max_angular_speed {c.max_angular_speed}")
            last = goals[-1]
            expect(abs(float(np.hypot(last[0], last[1])) - c.max_linear_speed) < 1e-6
                   and abs(last[2] - c.max_angular_speed) < 1e-6, self.kind, SPEED,
                   f"after {len(goals)} cycles the twist written is {fmt(last)}, not at the limits "
                   f"[{c.max_linear_speed}, 0, {c.max_angular_speed}]")

    def test_the_twist_changes_at_most_max_accel_per_cycle(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop = self._start(node)
            c = node.config
            lin_step, ang_step = self._steps(node)
            before = loop.goals[-1] if loop.goals else np.zeros(3)
            n0 = len(loop.writes)
            self._stream(node, loop, np.array([c.max_linear_speed, 0.0, c.max_angular_speed]), 8)
            self._stream(node, loop, np.array([-c.max_linear_speed, 0.0, -c.max_angular_speed]), 8)
            goals = [before] + loop.goals[n0:]
            expect(len(goals) > 4, self.kind, ACCEL, f"{len(goals) - 1} twists written in 16 cycles")
            for k in range(1, len(goals)):
                d = goals[k] - goals[k - 1]
                expect(float(np.hypot(d[0], d[1])) <= lin_step + 1e-9 and abs(d[2]) <= ang_step + 1e-9, self.kind,
                       ACCEL, f"the twist written went from {fmt(goals[k - 1])} to {fmt(goals[k])} in one cycle; "
                              f"the limits are {lin_step:.4f} m/s and {ang_step:.4f} rad/s per cycle")
            # each command is due one cycle ahead (interpolated), so the first cycle of a ramp moves little
            expect(abs(goals[8][0]) >= 0.99 * min(c.max_linear_speed, 6 * lin_step), self.kind, ACCEL,
                   f"the twist written reached only {fmt(goals[8])} after 8 cycles of full commands")

    def test_a_silent_stream_is_stopped_by_the_watchdog(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop = self._start(node)
            watchdog, period = float(node.config.watchdog_s), 1.0 / node.rate_hz
            twist = self.drive(node)
            t_last = self._stream(node, loop, twist, self._ramp_cycles(node, twist) + 3, self.settle_s)
            moving = loop.goals[-1]
            expect(np.allclose(moving, twist, atol=1e-9), self.kind, STOPS,
                   f"after a stream of {fmt(twist)} the twist written is {fmt(moving)}")
            ramp_s = float(np.hypot(twist[0], twist[1])) / node.config.max_linear_accel
            written: list[tuple[float, np.ndarray]] = []  # (time after the last command, twist) per cycle
            ramp_cycles, stopped_for = self._ramp_cycles(node, twist), 0
            while clock.now() - t_last < watchdog + ramp_s + self.settle_s + 0.1 or stopped_for < ramp_cycles + 5:
                n0 = len(loop.writes)
                loop.tick()
                written += [(clock.now() - t_last, g) for g in loop.goals[n0:]]
                if clock.now() - t_last > watchdog:  # the ramp down runs per cycle, however slow they come
                    stopped_for += 1
            expect(written, self.kind, STOPS, "nothing was written to the driver while enabled")
            slowed = next((t for t, g in written if not np.allclose(g, moving, atol=1e-9)), None)
            expect(slowed is not None and slowed >= watchdog - 2 * period, self.kind, STOPS,
                   f"the base was slowed {slowed:.3f} s after the last command, before watchdog_s {watchdog}"
                   if slowed is not None else "the twist written never changed after the stream went silent")
            last = written[-1][1]
            expect(np.abs(last).max() < 1e-12, self.kind, STOPS,
                   f"{written[-1][0]:.2f} s after the last command the twist written is {fmt(last)}, not zero "
                   f"(watchdog_s {watchdog})")
            s = loop.last
            expect(s is not None and s["holding"], self.kind, STOPS,
                   f"`holding` is false {clock.now() - t_last:.2f} s after the last command")
            measured = np.asarray(s["body_twist"], dtype=np.float64)
            expect(np.abs(measured).max() <= self.tracking_tol, self.kind, STOPS,
                   f"the base still moves at {fmt(measured)} after the watchdog stopped it (tracking_tol "
                   f"{self.tracking_tol})")

    def test_disabled_refuses_commands_and_enable_does_not_start_it(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop = self._start(node)
            twist = self.drive(node)
            self._stream(node, loop, twist, 5)
            node.disable()
            try:
                self.command(node, twist, clock.now())
            except InvalidRequest as e:
                expect(e.node == node.name, self.kind, DISABLED, f"the InvalidRequest names node '{e.node}'")
            else:
                violated(self.kind, DISABLED, "a twist sent to the disabled base was accepted")
            n0, s0 = len(loop.writes), len(loop.samples)
            loop.run(cycles=5)
            expect(len(loop.writes) == n0, self.kind, DISABLED,
                   f"{len(loop.writes) - n0} twists written to the driver in 5 cycles while disabled")
            for s in loop.samples[s0:]:
                expect(not s["enabled"] and s["holding"], self.kind, DISABLED,
                       f"a sample while disabled has enabled={s['enabled']}, holding={s['holding']}")
            node.enable()
            n0 = len(loop.writes)
            loop.run(seconds=self.settle_s)
            loop.run(cycles=self._ramp_cycles(node, twist) + 3)  # from the twist measured at enable down to zero
            goals = loop.goals[n0:]
            expect(goals, self.kind, ENABLE, "nothing written to the driver after enable()")
            bad = [g for g in goals if np.hypot(g[0], g[1]) > float(np.hypot(*loop.goals[n0][:2])) + 1e-9]
            expect(not bad, self.kind, ENABLE,
                   lambda: f"after enable() with no command the twist written rose to {fmt(bad[0])}")
            expect(np.abs(goals[-1]).max() < 1e-12 and loop.last["holding"], self.kind, ENABLE,
                   f"after enable() with no command the base is driven at {fmt(goals[-1])}")

    def test_odometry_follows_a_straight_drive(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop = self._start(node)
            node.reset_odometry()
            twist = self.drive(node)
            self._stream(node, loop, twist, self._ramp_cycles(node, twist) + 20, 1.0)
            pose = np.asarray(loop.last["odom_pose"], dtype=np.float64)
            travelled = float(np.hypot(pose[0], pose[1]))
            expect(pose[0] > 0.02, self.kind, ODOMETRY,
                   f"after driving at {fmt(twist)} for 1 s or more odom_pose is {fmt(pose)}: it did not move forward")
            expect(abs(pose[1]) <= 0.1 * travelled + 0.005 and abs(pose[2]) <= 0.05, self.kind, ODOMETRY,
                   f"after driving straight ahead at {fmt(twist)} odom_pose is {fmt(pose)}: it drifted sideways or "
                   "turned")

    def test_closing_stops_the_base(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop = self._start(node)
            self._stream(node, loop, self.drive(node), 5)
            moving = loop.goals[-1]
        expect(np.abs(moving).max() > 0, self.kind, CLOSES, "the base was not driven before closing")
        expect(np.abs(loop.goals[-1]).max() < 1e-12, self.kind, CLOSES,
               f"the last twist written before the node closed is {fmt(loop.goals[-1])}")
