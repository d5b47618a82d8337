"""`run_eval`: a policy's success rate on a station's task, over N seeded trials (`rio eval`).

Trial k is episode k of a run seeded `seed`: the task's sensor (a sim world's `[task]`) starts it from the draw
of (seed, k), so the same command on the same station meets the same starts, and a trial's start does not
depend on the trials before it. The policy runs exactly as under `rio deploy` (`PolicyController`: its own
node, asynchronous chunked inference), started once; the station keeps running across trials. Before each
trial the robot goes back to where the station started it (`return_home`: a straight line through `env.step`
to the session's first proprio, then still), then `Env.reset(seed, k)` puts the task's objects at that
episode's start (every other object back where the scene has it) and restarts its clock, and the policy starts
a new episode (`PolicyController.reset`).

A trial ends when the task's success has held `hold_s` seconds of task time (the scripted expert's 0.3 s),
at the task's time limit, or when the policy stops (its node died: the evaluation ends there and says so).
Its time is the task time at which the success that held began (a completion time), else the time it ran.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from rio import clock
from rio.errors import NodeDiedError, RioError
from rio.loop.control_loop import ControlLoop, Tick
from rio.loop.summary import RunSummary, plain
from rio.policy.async_inference import AsyncConfig
from rio.policy.deploy import POLICY_ROLE, PolicyController

#: Task time the success must hold before a trial counts as done (the scripted expert's `HOLD_S`).
HOLD_S = 0.3
#: Seconds the robot takes to go back to its start between trials, the longest wait for it to be still then.
HOME_S, STILL_TIMEOUT_S = 1.0, 3.0


@dataclass
class Trial:
    """One trial: episode `episode` of the run seeded `seed` (its start drawn from `episode_seed`)."""

    trial: int
    seed: int | None
    episode: int
    episode_seed: int | None
    success: bool
    #: the completion time (task s) when it succeeded, else the task time it ran for
    time_s: float
    #: why it ended (success held, the time limit, the policy stopped, a signal)
    ended: str
    #: wall-clock seconds of the trial's loop (not counting going home and settling)
    wall_s: float
    warnings: list[str] = field(default_factory=list)


@dataclass
class EvalResult:
    station: str
    policy: str
    seed: int | None
    trials_asked: int
    trials: list[Trial] = field(default_factory=list)
    hold_s: float = HOLD_S
    #: a node failed (the policy stopped, another node died): what, and the evaluation ended there
    failed: str | None = None
    #: the signal that ended the evaluation early, if one did
    signal: str | None = None
    seconds: float = 0.0
    #: the policy's metadata and inference statistics over all trials (`PolicyController.finish`)
    details: dict[str, Any] = field(default_factory=dict)
    lines: list[str] = field(default_factory=list)

    @property
    def successes(self) -> int:
        return sum(t.success for t in self.trials)

    @property
    def success_rate(self) -> float | None:
        return self.successes / len(self.trials) if self.trials else None

    def completion_s(self) -> dict[str, float] | None:
        """Mean and median completion time of the successful trials (task seconds); None without one."""
        times = [t.time_s for t in self.trials if t.success]
        if not times:
            return None
        return {"mean": round(statistics.fmean(times), 3), "median": round(statistics.median(times), 3)}

    @property
    def complete(self) -> bool:
        """Every trial asked for ran, and no node failed."""
        return self.failed is None and self.signal is None and len(self.trials) == self.trials_asked

    def format(self) -> str:
        n = len(self.trials)
        rate = f"{self.successes}/{n} trials succeeded ({100 * self.successes / n:.0f}%)" if n else "no trial ran"
        seed = f"seed {self.seed}" if self.seed is not None else "the task's seed"
        out = [f"eval of '{self.policy}' on '{self.station}' ({seed}): {rate}"]
        c = self.completion_s()
        if c is not None:
            out.append(f"  completion time of the successes: mean {c['mean']:.2f} s, median {c['median']:.2f} s "
                       "(task time)")
        out.append(f"  {'trial':>5}  {'episode seed':>12}  {'success':>7}  {'time s':>6}  ended")
        for t in self.trials:
            es = "-" if t.episode_seed is None else str(t.episode_seed)
            out.append(f"  {t.trial:>5}  {es:>12}  {'yes' if t.success else 'no':>7}  {t.time_s:>6.2f}  {t.ended}")
        if self.trials:
            wall = [t.wall_s for t in self.trials]
            out.append(f"  {self.seconds:.1f} s in all; a trial's loop ran {min(wall):.1f}-{max(wall):.1f} s")
        out += ["  " + line for line in self.lines]
        for t in self.trials:
            out += [f"  WARNING: trial {t.trial}: {w}" for w in t.warnings]
        if self.failed:
            out.append(f"  FAILED: {self.failed}; {len(self.trials)} of {self.trials_asked} trials ran")
        elif self.signal:
            out.append(f"  stopped by {self.signal} after {len(self.trials)} of {self.trials_asked} trials")
        return "\n".join(out)

    def to_json(self) -> dict[str, Any]:
        """Plain JSON types only (`--json`)."""
        return {"station": self.station, "policy": self.policy, "seed": self.seed, "trials_asked": self.trials_asked,
                "successes": self.successes, "success_rate": self.success_rate, "completion_s": self.completion_s(),
                "hold_s": self.hold_s, "trials": [asdict(t) for t in self.trials], "failed": self.failed,
                "signal": self.signal, "complete": self.complete, "seconds": round(self.seconds, 3),
                "details": plain(self.details)}


class EvalController(PolicyController):
    """`PolicyController` that also ends the episode once the task's success has held `hold_s` (task time),
    and remembers a policy that stopped."""

    name = "eval"
    hold_s = HOLD_S
    stopped: NodeDiedError | None = None
    completed_at: float | None = None

    def reset(self, loop: Any) -> None:
        super().reset(loop)
        self.completed_at = None

    def done(self) -> str | None:
        held = self.env.task_success_held()
        if held is not None and held[1] >= self.hold_s:
            self.completed_at = held[0]
            return f"success held {self.hold_s:g} s"
        return super().done()

    def node_died(self, error: NodeDiedError) -> bool:
        if super().node_died(error):
            self.stopped = error
            return True
        return False


def return_home(env: Any, start: np.ndarray, rate_hz: float, seconds: float = HOME_S,
                timeout: float = STILL_TIMEOUT_S) -> bool:
    """Bring the robot back to `start` (an action: the session's first `proprio`, where the station started
    it), commanding a straight line to it through `env.step` over `seconds` at `rate_hz`, as a controller
    streams commands (so the drivers' stale-command watchdog sees a stream that ends at its target), then wait
    (at most `timeout`) until the proprio is still. False if it was still moving then."""
    dt = 1.0 / rate_hz
    t0 = clock.now()
    begin = np.asarray(env.get_state().observation.proprio, dtype=np.float64)
    while float(np.max(np.abs(begin - start), initial=0.0)) > 1e-3:  # not there yet (a fresh station is)
        now = clock.now()
        f = min(1.0, (now + dt - t0) / seconds) if seconds > 0 else 1.0
        env.step(begin + f * (start - begin), t_cmd_target=now + dt)
        if f >= 1.0:
            break
        clock.precise_wait(now + dt)
    return _wait_still(env, timeout)


def _wait_still(env: Any, timeout: float, period: float = 0.05, tol: float = 1e-4) -> bool:
    def proprio() -> np.ndarray:
        return np.asarray(env.get_state().observation.proprio, dtype=np.float64)

    prev, t_end = proprio(), clock.now() + timeout
    while clock.now() < t_end:
        clock.precise_wait(clock.now() + period)
        cur = proprio()
        if float(np.max(np.abs(cur - prev), initial=0.0)) < tol:
            return True
        prev = cur
    return False


def run_eval(station: Any, policy: str | None = None, *, trials: int = 10, seed: int | None = None,
             hold_s: float = HOLD_S, record: str | None = None, instruction: str | None = None,
             middleware: str | None = None, rate_hz: float | None = None, config: AsyncConfig | None = None,
             on_tick: Callable[[Tick], None] | None = None, on_trial: Callable[[Trial], None] | None = None,
             log: Callable[[str], None] | None = print, ready_timeout: float | None = None,
             profile: str | None = None, registry: Any = None) -> EvalResult:
    """Run `trials` trials of `policy` (a `--policy` SPEC; default: the station's policy component) on the
    task of `station` (registered name, .toml path or `Station`), trial k from the start of episode k of a
    run seeded `seed` (None: the task's own seed), and return what happened (see the module docstring).
    `record`: a dataset directory that keeps every trial as an episode (its task verdict in its metadata).
    `on_trial` is called with each trial as it ends. `ready_timeout`: as `run_deploy`'s. A station without a
    task is a `RioError`."""
    from rio.policy.resolve import resolve_policy
    from rio.station.edit import without_role
    from rio.workflows.deploy import POLICY_READY_S
    from rio.workflows.run import open_session
    from rio.workflows.teleop import prepare_station

    if trials < 1:
        raise RioError(f"rio eval: trials must be at least 1 (got {trials})")
    if not hold_s >= 0:
        raise RioError(f"rio eval: the success hold must be >= 0 s (got {hold_s})")
    say = log or (lambda _m: None)
    st = prepare_station(station, registry=registry)
    name, node_cls, policy_kwargs = resolve_policy(policy, st, registry)
    result = EvalResult(st.name, name, seed, trials, hold_s=hold_s)
    t0 = clock.now()
    with open_session(without_role(st, POLICY_ROLE), middleware=middleware, rate_hz=rate_hz, instruction=instruction,
                      profile=profile, registry=registry, log=log, seed=seed, ready_timeout=ready_timeout) as session:
        env, stop = session.env, session.stop
        start = np.asarray(env.reset().observation.proprio, dtype=np.float64)  # where the station starts the robot
        if env.task_result() is None:
            raise RioError(f"station '{st.name}' runs no task (a sensor with one, such as a sim world's [task]): "
                           "rio eval has no success to measure; run the policy with rio deploy")
        ctl = EvalController.start(session, name, node_cls, policy_kwargs, config or AsyncConfig(),
                                   ready_timeout=ready_timeout or POLICY_READY_S)
        ctl.hold_s = hold_s
        recorder = None
        if record:
            from rio.recording import Recorder

            recorder = session.stack.enter_context(Recorder(record, fps=session.rate_hz, env=env,
                                                            instruction=instruction,
                                                            metadata={"source": "rio eval", "policy": name}))
        prof = session.profile
        for k in range(trials):
            if stop.received:
                break
            env.seed, env.episode = seed, k
            loop = ControlLoop(env, ctl, rate_hz=session.rate_hz, recorder=recorder, on_tick=on_tick, stop=stop,
                               trace=prof.trace if prof is not None else None, log=say if k == 0 else None)
            try:
                if not return_home(env, start, session.rate_hz):
                    say(f"trial {k}: the robot was still moving {STILL_TIMEOUT_S:g} s after going back to its "
                        "start; starting anyway")
                summary = loop.run()
            except NodeDiedError as e:  # a station node: the trial cannot be judged, nor the next ones run
                result.failed = str(e)
                break
            if recorder is not None:
                recorder.keep()  # with the task's verdict (the loop annotated it); an empty trial is dropped
            trial = _trial(k, seed, summary, ctl.completed_at, env.task_success_held())
            result.trials.append(trial)
            say(f"trial {k + 1}/{trials}: {'success' if trial.success else 'failure'} "
                f"({trial.time_s:.1f} s; {trial.ended})")
            if on_trial is not None:
                on_trial(trial)
            if ctl.stopped is not None:
                result.failed = f"the policy stopped ({ctl.stopped})"
                break
            if summary.signal:
                result.signal = summary.signal
                break
        s = _details(ctl)
        result.details, result.lines = s.details, s.lines
    if session.stop.received and not result.signal and len(result.trials) < trials:
        result.signal = session.stop.received
    if record:
        result.lines.append(f"recorded to {record}")
    if session.profile is not None:
        result.lines += session.profile.summary_lines()
    result.seconds = clock.now() - t0
    return result


def _trial(k: int, seed: int | None, summary: Any, completed_at: float | None,
           held: tuple[float, float] | None) -> Trial:
    """The trial from its loop's summary; its completion time is when the success that ended it began
    (`completed_at`), or, for one still succeeding at the time limit, when its success began (`held`)."""
    task = summary.task or {}
    success = bool(summary.success)
    completed = completed_at if completed_at is not None else held[0] if held is not None else None
    time_s = float(completed) if success and completed is not None else float(task.get("time_s", 0.0))
    return Trial(k, task.get("seed", seed), int(task.get("episode", k)), task.get("episode_seed"), success,
                 round(time_s, 3), summary.reason, round(summary.seconds, 3), list(summary.warnings))


def _details(ctl: EvalController) -> RunSummary:
    """The policy's figures over every trial, as `PolicyController.finish` writes them into a summary."""
    s = RunSummary("eval", "")
    ctl.finish(s)
    return s
