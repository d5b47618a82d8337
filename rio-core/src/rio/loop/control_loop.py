"""`ControlLoop`: the one loop every workflow runs (teleop, leader-follower, deploy, replay, yours).

The RIO paper's cycle, written once: each period of `1 / rate_hz` the loop wakes at mid-cycle, hands
the controller the latest observation, and sends the action it returns to be reached one period
after this cycle ends (`t_target`), so drivers interpolate smoothly between commands. The loop owns
what every workflow needs and used to write for itself: pacing, wake-up lateness and overrun
accounting (a loop that fell a whole period behind re-anchors instead of bursting), the episode
boundary (`env.reset()` before, settling after), recording each step, ending on the controller's
word, a duration, the task's time limit (`env.task_over()`) or a signal (`rio.loop.signals`), tracking
commanded against measured (`rio.loop.tracking`), profiling spans, and the end `RunSummary` (with the
task's verdict, `env.task_result()`, also given to the recorder as the episode's metadata).

A controller is a small object (see `Controller`); everything else is optional, looked up by name:

    class Wave:
        name = "wave"
        def reset(self, loop): self.q0 = loop.env.get_state().observation.proprio.copy()
        def step(self, tick): return self.q0 + 0.2 * np.sin(tick.t - tick.t0)
        def done(self): return None

    summary = ControlLoop(env, Wave(), rate_hz=30, duration=10).run()

docs/controllers.md has the whole protocol and `rio run STATION --controller module:Class`.
"""

from __future__ import annotations

import contextlib
import gc
import logging
import os
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from rio import clock
from rio.control.reservoir import Reservoir
from rio.errors import NodeDiedError
from rio.loop.health import NodeHealth
from rio.loop.signals import StopSignals
from rio.loop.summary import ERROR, RunSummary
from rio.loop.tracking import ArmTracker, ObjectWatch

log = logging.getLogger("rio.loop")

#: At the end of a run, the longest wait for the arms' last motion to end before the summary measures them.
SETTLE_MAX_S = 2.0


@dataclass
class Tick:
    """One control cycle, handed to the controller's `step` and to `on_tick` callbacks."""

    t: float  # when this tick reads its inputs (mid-cycle for periodic ticks)
    t_target: float  # when its command is to be reached
    t0: float  # the loop's start time
    it: int
    periodic: bool  # False for an extra tick a controller asked for (`wait`)
    obs: Any  # the latest Step before acting (from env.reset() or the previous tick)
    env: Any
    t_sent: float = 0.0  # when the action went to env.step
    step: Any = None  # what env.step returned: the fresh state, tagged with the action
    action: np.ndarray | None = None
    lateness: float = 0.0  # how late the loop woke for this (periodic) tick, seconds
    #: what the controller shows of this tick (teleop: devices, arms, mode; deploy: sample, chunk; ...)
    info: dict[str, Any] = field(default_factory=dict)


class Controller(Protocol):
    """What a workflow plugs into the loop. Optional, looked up by name:

    - `after(tick)`: runs once the action is out and `tick.step` holds the fresh state (deploy sends
      that observation for inference here);
    - `wait(deadline) -> bool`: sleep until `deadline`, or return True earlier to take an extra,
      non-periodic tick at once (deploy: a chunk just landed);
    - `node_died(error)`: a node stopped during the run (`NodeDiedError`); the run ends there with the robot
      holding its last command, the summary naming the node (an `error` event), whatever this returns;
    - `finish(summary)`: add the workflow's figures (`summary.details`) and lines (`summary.lines`).
    """

    name: str

    def reset(self, loop: ControlLoop) -> None: ...

    def step(self, tick: Tick) -> np.ndarray | None:
        """The flat action to be reached at `tick.t_target`; None holds the last command."""
        ...

    def done(self) -> str | None:
        """Why the run should end now (e.g. "the device finished"), or None to go on."""
        ...


class ControlLoop:
    """Run `controller` on a connected `env` (`with env:`) at `rate_hz` until the controller is done,
    `duration` seconds pass, or a stop signal. `recorder`: a `rio.recording.Recorder` given every step.
    `lead_s`: how far past the cycle's end a command's target lies (default: one period)."""

    def __init__(self, env: Any, controller: Any, *, rate_hz: float, duration: float | None = None,
                 recorder: Any = None, on_tick: Callable[[Tick], None] | None = None, lead_s: float | None = None,
                 stop: StopSignals | None = None, trace: Any = None, settle: bool = True,
                 freeze_gc: bool = True, realtime: bool | None = None, cpu: int | None = None,
                 gil_switch_s: float | None = None, log: Callable[[str], None] | None = print):
        if rate_hz <= 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self.env, self.controller, self.recorder, self.on_tick = env, controller, recorder, on_tick
        self.rate_hz, self.dt, self.duration = float(rate_hz), 1.0 / float(rate_hz), duration
        self.lead_s = self.dt if lead_s is None else float(lead_s)
        self.stop, self.trace, self.settle = stop, trace, settle
        if realtime is None:  # where permitted, unless RIO_LOOP_REALTIME=0
            realtime = None if os.environ.get("RIO_LOOP_REALTIME", "") not in ("0", "false", "no") else False
        self.freeze_gc, self.realtime, self.cpu = freeze_gc, realtime, cpu
        #: The interpreter's thread switch interval during the run (None: Python's 5 ms): how long the loop,
        #: woken at its deadline, can wait for a Python thread of its own process (a node on the thread
        #: middleware, a network middleware's receiver) to hand over the GIL.
        self.gil_switch_s = gil_switch_s
        self.say = log or (lambda _m: None)
        self.summary = RunSummary(getattr(controller, "name", type(controller).__name__), env.station,
                                  rate_hz=self.rate_hz, instruction=env.instruction)
        self.obs: Any = None
        self.last_action: np.ndarray | None = None
        self.t0 = 0.0

    # -- helpers for controllers --------------------------------------------------------------------
    def phase(self, name: str) -> contextlib.AbstractContextManager[Any]:
        """Time a block on the loop's profiling track (a no-op unless `--profile`)."""
        return self.trace.phase("control loop", name) if self.trace is not None else contextlib.nullcontext()

    # -- the loop -------------------------------------------------------------------------------------
    def run(self) -> RunSummary:
        with contextlib.ExitStack() as stack:
            stop = self.stop or stack.enter_context(StopSignals())
            return self._run(stop)

    def _run(self, stop: StopSignals) -> RunSummary:
        env, ctl, s, dt = self.env, self.controller, self.summary, self.dt
        try:
            self.obs = env.reset()
            ctl.reset(self)  # (a replay's approach to its first action runs here)
            tracker, objects = ArmTracker(env.robot), ObjectWatch(env.sensors)
            self.health = NodeHealth(env.robot.clients, s, getattr(env.robot, "samples", None))
        except NodeDiedError as e:  # before the first tick: nothing ran that could be measured
            s.reason = f"node '{e.node}' stopped with an error before the first tick"
            s.add_event(ERROR, e.node, e.detail or str(e))
            return s
        published = self._publish_rates()
        if self.recorder is not None and "embodiment" not in self.recorder.info:
            self.recorder.describe_env(env)
        wait = getattr(ctl, "wait", None) or clock.precise_wait
        lateness = Reservoir()
        clock.set_timer_slack()  # this thread's sleeps wake on time (see rio.clock)
        with _scheduled(self.realtime, self.cpu, self.say), _switch_interval(self.gil_switch_s), \
                _collector_paused() if self.freeze_gc else contextlib.nullcontext():
            self.t0 = t_start = clock.now()
            env.set_start_time(t_start)
            self._loop(stop, wait, t_start, tracker, objects, lateness)
        s.seconds = clock.now() - t_start
        if self.settle:  # let the arms arrive at their last targets before measuring
            clock.precise_wait(clock.now() + self.lead_s + 2 * dt)
            _unless_gone(lambda: tracker.wait_still(SETTLE_MAX_S))
        self._hold_robot()
        self._finish(tracker, objects, published, lateness)
        return s

    def _hold_robot(self) -> None:
        """Tell every commanded node that its stream of commands ends here (`hold()`): the end of a run is
        announced, so a node's stale-command watchdog keeps its warning for a silence nobody announced (a
        stalled controller, a pulled cable). A node that stopped cannot answer; it is reported elsewhere."""
        for client in self.env.robot.clients.values():
            try:
                hold = getattr(client, "hold", None)
                if callable(hold):
                    hold()
            except Exception as e:  # a dead node, a lost link: the summary's events say so
                log.debug("hold at the end of the run: %s", e)

    def _loop(self, stop: StopSignals, wait: Callable[[float], Any], t_start: float, tracker: ArmTracker,
              objects: ObjectWatch, lateness: Reservoir) -> None:
        env, ctl, s, dt = self.env, self.controller, self.summary, self.dt
        task_over = getattr(env, "task_over", None) or (lambda: None)
        grid = clock.Schedule(dt, t_start, phase=0.5)  # wake mid-cycle
        s.reason = "duration reached"
        try:
            while True:
                if stop.received:
                    s.reason, s.signal = f"stopped by {stop.received}", stop.received
                    break
                t_sample = grid.deadline
                if wait(t_sample):  # the controller wants a tick now (it had something arrive)
                    now = clock.now()
                    self._tick(Tick(now, now + dt / 2 + self.lead_s, t_start, grid.k, False, self.obs, env),
                               tracker, objects)
                    continue
                woke_late = clock.now() - t_sample
                lateness.add(woke_late)
                self._tick(Tick(t_sample, t_sample + dt / 2 + self.lead_s, t_start, grid.k, True, self.obs, env,
                                lateness=woke_late), tracker, objects)
                grid.advance()
                s.ticks += 1
                late = clock.now() - grid.deadline  # past the next tick's wake-up
                if late > 0:
                    s.late_ticks += 1
                    if late > dt:  # fell a whole period behind: re-anchor, no burst
                        s.overruns += 1
                        grid.reanchor(clock.now())
                reason = ctl.done() or task_over()
                if reason:
                    s.reason = reason
                    break
                if self.duration is not None and clock.now() - t_start >= self.duration:
                    break
        except KeyboardInterrupt:
            s.reason, s.signal = "interrupted (Ctrl+C)", "SIGINT"
        except NodeDiedError as e:
            self._node_died(e, t_start)

    def _tick(self, tick: Tick, tracker: ArmTracker, objects: ObjectWatch) -> None:
        env, ctl = self.env, self.controller
        with self.phase("controller"):
            action = ctl.step(tick)
        if action is None:
            action = self.last_action
        tick.t_sent = clock.now()
        with self.phase("send action + read state"):
            step = env.step(action, t_cmd_target=tick.t_target) if action is not None else env.get_state()
        if action is not None:
            self.last_action = np.asarray(action, dtype=np.float64)
            tracker.commanded(self.last_action, tick.t_target)
        tick.step, tick.action, self.obs = step, self.last_action, step
        after = getattr(ctl, "after", None)
        if after is not None:  # before the bookkeeping: deploy sends the fresh observation from here
            after(tick)
        tracker.measure(tick.t)
        objects.update()
        self.health.check(tick.t - tick.t0)
        if self.recorder is not None and action is not None:
            with self.phase("record"):
                self.recorder.add(step)
        if self.on_tick is not None:
            self.on_tick(tick)

    def _node_died(self, e: NodeDiedError, t_start: float) -> None:
        """A node stopped during the run: the run ends here, the robot holding its last command (where the
        node that stopped is not the one to hold it), and the summary says which node and why."""
        env, s = self.env, self.summary
        s.reason = f"node '{e.node}' stopped with an error; the robot holds its last command"
        s.add_event(ERROR, e.node, e.detail or str(e), clock.now() - t_start)
        died = getattr(self.controller, "node_died", None)
        if died is not None:
            died(e)
        if self.last_action is not None:
            try:
                env.step(self.last_action, t_cmd_target=clock.now() + self.dt)
                s.details["held"] = [float(x) for x in self.last_action]
            except NodeDiedError:  # the node that stopped is one the action goes to
                pass

    def _publish_rates(self) -> dict[str, clock.CountRate]:
        """A publish-rate meter per node with state, started now (read once more at the end)."""
        env = self.env
        clients = {**env.robot.clients, **env.cameras, **env.sensors}
        meters = {role: clock.CountRate(c.published) for role, c in clients.items() if "published" in dir(c)}
        return {role: m for role, m in meters.items() if m.last is not None}

    def _finish(self, tracker: ArmTracker, objects: ObjectWatch, published: dict[str, clock.CountRate],
                lateness: Reservoir) -> None:
        s = self.summary
        s.arms, s.objects = tracker.report(), _unless_gone(objects.report, [])
        self.health.finish()
        for role, meter in published.items():
            rate = _unless_gone(meter.rate)
            if rate is not None:
                s.node_rates_hz[role] = round(rate, 1)
        task = _unless_gone(getattr(self.env, "task_result", lambda: None))
        if task is not None:
            s.task, s.success = task, bool(task["success"])
            if self.recorder is not None and "annotate" in dir(self.recorder):
                self.recorder.annotate(task=task)
        p50, p99 = lateness.percentile(50), lateness.percentile(99)
        if p50 is not None and p99 is not None:
            s.lateness_us = {"p50": round(p50 * 1e6, 1), "p99": round(p99 * 1e6, 1),
                             "max": round(lateness.max * 1e6, 1)}
        finish = getattr(self.controller, "finish", None)
        if finish is not None:
            finish(s)
        for role, skipped in getattr(self.env.robot, "behind", {}).items():
            s.warnings.append(f"{role}: {skipped} command(s) not sent: its node was behind on the network link "
                              "(every request credit in flight); each was superseded by the next cycle's")
        for a in s.arms:
            if a.clipped:
                s.warnings.append(f"{a.role}: {a.clipped} of {a.commands} commands asked for the tool outside its "
                                  "workspace box and were clipped to it (the tool held at the box's edge)")
            if not a.followed:
                why = ("most of what it was commanded lay outside its workspace box" if a.clipped else
                       "disabled, e-stopped, in another control mode, or commands not reaching it")
                s.warnings.append(f"{a.role} was commanded over {a.commanded_path_m:.3f} m / "
                                  f"{a.commanded_joint_path_rad:.3f} rad but moved {a.path_m:.3f} m / "
                                  f"{a.joint_path_rad:.3f} rad: it did not follow ({why})")


def _unless_gone(measure: Callable[[], Any], default: Any = None) -> Any:
    """`measure()`, or `default` when a node it reads has stopped (the summary names that node already)."""
    try:
        return measure()
    except NodeDiedError:
        return default


@contextlib.contextmanager
def _scheduled(realtime: bool | None, cpu: int | None, say: Callable[[str], None]) -> Iterator[None]:
    """OS scheduling for the loop's thread while it runs: SCHED_FIFO at priority 10 (`realtime`: None
    tries it quietly, True says when it cannot; it needs root or CAP_SYS_NICE) and pinning to one CPU.
    On a loaded 2-core machine SCHED_FIFO cut the 500 Hz loop's p99 wake-up lateness from ~2 ms to
    ~40 us (bench/loop_jitter.py). It cannot starve the machine: the loop sleeps every cycle and
    spins at most 200 us before a deadline. The thread's old settings come back afterwards."""
    undo = []
    if realtime is not False:
        try:
            old = (os.sched_getscheduler(0), os.sched_getparam(0))
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
            undo.append(lambda: os.sched_setscheduler(0, old[0], old[1]))
        except (AttributeError, OSError) as e:
            if realtime:
                say(f"realtime scheduling not available ({e}); running with the default scheduler")
    if cpu is not None:
        try:
            cpus = os.sched_getaffinity(0)
            os.sched_setaffinity(0, {int(cpu)})
            undo.append(lambda: os.sched_setaffinity(0, cpus))
        except (AttributeError, OSError) as e:
            say(f"cannot pin the loop to CPU {cpu} ({e})")
    try:
        yield
    finally:
        for u in reversed(undo):
            with contextlib.suppress(OSError):
                u()


@contextlib.contextmanager
def _switch_interval(seconds: float | None) -> Iterator[None]:
    """`sys.setswitchinterval(seconds)` while the loop runs (process-wide; restored afterwards)."""
    if seconds is None:
        yield
        return
    old = sys.getswitchinterval()
    sys.setswitchinterval(seconds)
    try:
        yield
    finally:
        sys.setswitchinterval(old)


@contextlib.contextmanager
def _collector_paused() -> Iterator[None]:
    """No full garbage collection inside the loop: what exists before it is frozen out of the
    collector's reach (`gc.freeze`), so a collection pass walks only what the loop allocates. Only the
    young generations are collected first, never a full pass: a full pass walks every object of the
    process holding the GIL (0.05-0.14 s measured in a short test session on a loaded 2-core machine,
    0.5-1 s in a process holding millions of objects), and the process's other threads starved with
    it at the worst moment: a scripted device started in the controller's `reset()` played on unseen
    (squares ended up to 22 mm open), an in-process emulated T1 published no state for 0.25-0.6 s and
    its driver faulted (lowstate_timeout). Old garbage frozen with the rest is collected after the run."""
    gc.collect(1)
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
