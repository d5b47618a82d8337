"""`run_deploy`: the RIO paper's policy-agnostic, hardware-agnostic inference script, written once
against `Env` and node clients. `rio deploy STATION --policy SPEC` runs exactly this.

Start-up: the station is started without its policy component; its first observation fixes the
`ObsLayout`, with which the policy node is started in its own node (over the station's middleware) and
loads its model. Then, every `1 / rate_hz` seconds, the control loop:

1. takes in a chunk if one arrived (a local ring-buffer read, `AsyncInference.poll`);
2. samples the aligned, blended schedule for the command's target time, one period ahead;
3. `env.step()`s it (a queue put) and gets the fresh observation back;
4. sends that observation for inference when the chunk in use is running low.

Between ticks, while an observation is in flight, the loop waits in short slices and runs steps 1-4
at once when its chunk lands, instead of at the next tick: the new chunk's first action reaches the
robot within a fraction of a millisecond of arriving, and the next observation goes out right away,
at any control rate. Periodic ticks keep their schedule either way.

Nothing blocks on the policy. Before the first chunk the robot holds its starting state; when the
policy is late the schedule holds or continues (`AsyncConfig.on_late`) and the event is counted. If
the policy node dies, the run stops with the robot holding its last command and the summary names the
node. `--record DIR` records every step as an episode with the station's recorder.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import clock
from ..errors import NodeDiedError, RioError
from ..schema import Step
from .async_inference import AsyncConfig, AsyncInference
from .base import ActionChunk, PolicyMetadata
from .obs_layout import ObsLayout
from .schedule import Sample

POLICY_ROLE = "policy"
#: Sleep slice while waiting for a chunk between ticks (the bound on how late an arrival is seen).
_POLL_S = 0.0003


@dataclass
class DeployTick:
    """Handed to `on_tick` after every command (tests, recorders, displays)."""

    t: float
    t_target: float
    it: int
    periodic: bool
    step: Step
    action: np.ndarray
    sample: Sample | None
    chunk: ActionChunk | None


@dataclass
class DeploySummary:
    station: str
    policy: str
    rate_hz: float
    instruction: str | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    ticks: int = 0
    seconds: float = 0.0
    reason: str = ""
    #: AsyncInference.stats() plus the loop's own timing.
    stats: dict[str, Any] = field(default_factory=dict)
    record: str | None = None
    #: The command the robot was left holding when the policy node stopped.
    held: list[float] | None = None

    def format(self) -> str:
        s = self.stats
        lines = [f"deployed '{self.policy}' on '{self.station}' at {self.rate_hz:g} Hz for {self.seconds:.1f} s "
                 f"({self.ticks} ticks): {self.reason}"]
        if self.instruction:
            lines.append(f"  instruction: {self.instruction}")
        lines.append(f"  chunks {s.get('chunks', 0)} of {s.get('requests', 0)} requested; policy late "
                     f"{s.get('late_events', 0)} times ({s.get('late_ticks', 0)} ticks); "
                     f"{s.get('timeouts', 0)} timeouts")
        for key, label in (("forward_ms_p50", "forward pass"), ("first_action_ms_p50", "obs -> first action"),
                           ("overhead_ms_p50", "overhead"), ("action_age_ms_p50", "action age")):
            if s.get(key) is not None:
                lines.append(f"  {label:20s} p50 {s[key]:8.2f} ms")
        if s.get("loop_jitter_us_p99") is not None:
            lines.append(f"  loop period jitter   p99 {s['loop_jitter_us_p99']:8.0f} us; "
                         f"overruns {s.get('loop_overruns', 0)}")
        if self.record:
            lines.append(f"  recorded to {self.record}")
        return "\n".join(lines)


def _without_policy(st: Any) -> Any:
    return dataclasses.replace(st, components={r: c for r, c in st.components.items() if r != POLICY_ROLE})


def run_deploy(station: Any, policy: str | None = None, *, instruction: str | None = None,
               record: str | None = None, duration: float | None = None, middleware: str | None = None,
               rate_hz: float | None = None, config: AsyncConfig | None = None,
               on_tick: Callable[[DeployTick], None] | None = None, log: Callable[[str], None] | None = print,
               ready_timeout: float = 600.0, registry: Any = None) -> DeploySummary:
    """Run `policy` (a `--policy` SPEC; default: the station's policy component) on `station`
    (registered name, .toml path or `Station`) until `duration` seconds pass or Ctrl+C."""
    from ..manager import ServerManager, connect, serve
    from ..station.build import make_station
    from ..station.load import load_station
    from .resolve import resolve_policy

    say = log or (lambda _m: None)
    cfg = config or AsyncConfig()
    st = load_station(station, registry=registry)
    name, node_cls, policy_kwargs = resolve_policy(policy, st, registry)
    servers, clients, env = make_station(_without_policy(st), middleware=middleware, registry=registry)
    if env is None:
        raise RioError(f"station '{st.name}' has no arm or humanoid to drive (roles: {sorted(st.roles())})")
    mw = next(iter(clients.values())).mw  # the station's middleware, shared by all its nodes
    freq = float(rate_hz or st.rate_hz)
    summary = DeploySummary(st.name, name, freq, instruction, record=record)
    say(f"starting station '{st.name}' ({len(servers)} nodes over {mw.name}) ...")
    with ServerManager(servers, station=st.name), contextlib.ExitStack() as stack:
        stack.enter_context(env)
        env.instruction = instruction
        first = env.reset()
        layout = ObsLayout.of(first.observation).to_dict()
        say(f"loading policy '{name}' ...")
        policy_kwargs = {**policy_kwargs, "observation": layout}
        pserver = serve(node_cls, mw, name=POLICY_ROLE, **policy_kwargs)
        stack.enter_context(ServerManager([pserver], station=st.name, ready_timeout=ready_timeout))
        client = stack.enter_context(connect(node_cls, mw, name=POLICY_ROLE, **policy_kwargs))
        meta = PolicyMetadata.from_dict(client.metadata())
        summary.metadata = meta.to_dict()
        recorder = _open_recorder(record, env, freq, instruction, stack) if record else None
        say(f"policy '{meta.name}': chunks of {meta.horizon} x {meta.action_dim} at {meta.rate_hz:g} Hz; "
            f"control at {freq:g} Hz" + (f" for {duration:g} s" if duration else " until Ctrl+C"))
        loop = _Loop(env, client, AsyncInference(client, meta, cfg), freq, instruction, first, on_tick, recorder)
        loop.run(duration, summary)
    return summary


def _open_recorder(record: str, env: Any, fps: float, instruction: str | None, stack: contextlib.ExitStack) -> Any:
    """A `rio.recording.Recorder` writing this rollout as one episode of the dataset `record`."""
    from ..recording import Recorder

    return stack.enter_context(Recorder(record, fps=fps, env=env, instruction=instruction,
                                        metadata={"source": "rio deploy"}))


class _Loop:
    """The control loop's state; `run` is the loop."""

    def __init__(self, env: Any, client: Any, inf: AsyncInference, freq: float, instruction: str | None,
                 first: Step, on_tick: Callable[[DeployTick], None] | None, recorder: Any):
        self.env, self.client, self.inf = env, client, inf
        self.dt = 1.0 / freq
        self.instruction, self.on_tick, self.recorder = instruction, on_tick, recorder
        self.hold = np.asarray(first.observation.proprio, dtype=np.float64).copy()
        self.last = self.hold.copy()
        self.it = 0

    def _wait(self, deadline: float) -> bool:
        """Sleep until `deadline`; True as soon as an awaited chunk lands first (the early wake)."""
        inf = self.inf
        while inf.in_flight is not None:
            if inf.arrived():
                return True
            left = deadline - clock.now()
            if left <= _POLL_S:
                break
            time.sleep(_POLL_S)
        clock.precise_wait(deadline)
        return False

    def _tick(self, t: float, periodic: bool) -> None:
        inf = self.inf
        self.client.check_alive()
        chunk = inf.poll(t)
        t_target = t + self.dt
        s = inf.command(t_target)
        action = s.action if s is not None else self.hold
        t_applied = clock.now()
        step = self.env.step(action, t_cmd_target=t_target)
        if s is not None:
            inf.applied(s, t_applied)
        self.last = action
        if inf.wants_request(t):
            inf.request(step.observation, self.instruction, float(step.meta["t_obs"]), clock.now())
        if self.recorder is not None:
            self.recorder.add(step)
        if self.on_tick is not None:
            self.on_tick(DeployTick(t, t_target, self.it, periodic, step, action, s, chunk))

    def run(self, duration: float | None, summary: DeploySummary) -> None:
        dt = self.dt
        starts: list[float] = []
        overruns = 0
        clock.set_timer_slack()  # this thread's sleeps wake on time (see rio.clock)
        t_start = clock.now()
        self.env.set_start_time(t_start)
        summary.reason = "duration reached"
        try:
            while True:
                t_tick = t_start + self.it * dt
                if self._wait(t_tick):
                    self._tick(clock.now(), periodic=False)
                    continue
                t = clock.now()
                starts.append(t)
                self._tick(t, periodic=True)
                self.it += 1
                summary.ticks += 1
                if clock.now() - t_tick > dt:  # fell a whole period behind: re-anchor, no burst
                    overruns += 1
                    self.it = int((clock.now() - t_start) / dt) + 1
                if duration is not None and clock.now() - t_start >= duration:
                    break
        except KeyboardInterrupt:
            summary.reason = "interrupted (Ctrl+C)"
        except NodeDiedError as e:
            if e.node != POLICY_ROLE:
                raise
            summary.reason = f"policy node '{e.node}' stopped ({e}); the robot holds its last command"
            self.env.step(self.last, t_cmd_target=clock.now() + dt)
            summary.held = [float(x) for x in self.last]
        summary.seconds = clock.now() - t_start
        summary.stats = self.inf.stats()
        periods = np.diff(starts)
        summary.stats["loop_jitter_us_p99"] = (round(float(np.percentile(np.abs(periods - dt), 99)) * 1e6, 1)
                                               if periods.size else None)
        summary.stats["loop_overruns"] = overruns
