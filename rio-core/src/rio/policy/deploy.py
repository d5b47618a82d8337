"""`PolicyController`: the RIO paper's policy-agnostic, hardware-agnostic inference script, written once
against `Env` and node clients. `rio deploy STATION --policy SPEC` runs exactly this
(`rio.workflows.deploy.run_deploy`).

Start-up: the station is started without its policy component; its first observation fixes the
`ObsLayout`, with which the policy node is started in its own node (over the station's middleware) and
loads its model. Then `PolicyController` runs on the one control loop (`rio.loop.control_loop`); every
`1 / rate_hz` seconds it:

1. takes in a chunk if one arrived (a local ring-buffer read, `AsyncInference.poll`);
2. samples the aligned, blended schedule for the command's target time, one period ahead;
3. `env.step()`s it (a queue put) and gets the fresh observation back;
4. sends that observation for inference when the chunk in use is running low.

Between ticks, while an observation is in flight, the controller waits in short slices and runs steps 1-4
at once when its chunk lands, instead of at the next tick: the new chunk's first action reaches the
robot within a fraction of a millisecond of arriving, and the next observation goes out right away,
at any control rate. Periodic ticks keep their schedule either way.

On a station with an environment state (a sim world's object poses, `Env.environment_state`), the
observation the policy receives carries it in `Observation.environment_state`, the vector exports write
as `observation.environment_state`, so a policy trained on it reads the same values at deployment (the
recorded steps are left as they are). Each run of the loop (`reset`: one deploy, or one `rio eval` trial
on the same policy node) starts a new episode of the policy: chunks of the last one are dropped and the
policy resets with the first request.

Nothing blocks on the policy. Before the first chunk the robot holds its starting state; when the
policy is late the schedule holds or continues (`AsyncConfig.on_late`) and the event is counted. If
the policy node dies, the run stops with the robot holding its last command and the summary names the
node. `--record DIR` records every step as an episode with the station's recorder.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, TypeVar

import numpy as np

from rio import clock
from rio.errors import NodeDiedError
from rio.loop.control_loop import Tick
from rio.loop.summary import RunSummary
from rio.policy.async_inference import AsyncConfig, AsyncInference
from rio.policy.base import PolicyMetadata
from rio.policy.obs_layout import ObsLayout

POLICY_ROLE = "policy"
_Controller = TypeVar("_Controller", bound="PolicyController")
#: Waiting for a chunk between ticks: sleep slices of `_POLL_S` (the bound on how late an arrival is seen)
#: from `_NEAR_S` before it is expected (`AsyncInference.expected_arrival`), `_FAR_S` before that, when
#: no chunk can be there yet (fine slices all through an 86 ms forward pass would wake the loop ~900 times).
_POLL_S = 0.00005
_NEAR_S = 0.002
_FAR_S = 0.001


def _device_rings(session: Any) -> dict[str, dict[str, Any]]:
    """Ring references of the station's teleop devices, for a policy commanded by one (`ObsLayout.inputs`);
    a device whose middleware does not share rings has none."""
    from rio.station.roles import kind_of

    out = {}
    for role in sorted(session.clients):
        if kind_of(role) == "teleop":
            ref = getattr(session.stack.enter_context(session.clients[role]()), "ring_ref", None)
            if ref is not None:
                out[role] = ref
    return out


def with_environment(env: Any, step: Any) -> Any:
    """`step`'s observation with the env's environment state of that step in `environment_state` (a copy; the
    step, which the recorder keeps, is not changed), or the observation itself on a station without one."""
    state = env.environment_state(step)
    return step.observation if state is None else dataclasses.replace(step.observation, environment_state=state)


class PolicyController:
    """Controller (rio.loop.control_loop) over a running policy node: see the module docstring."""

    name = "deploy"

    def __init__(self, policy: str, client: Any, meta: PolicyMetadata, config: AsyncConfig, instruction: str | None,
                 env: Any = None):
        self.policy, self.client, self.meta, self.instruction = policy, client, meta, instruction
        self.inf = AsyncInference(client, meta, config)
        self.hold: np.ndarray | None = None
        self.sample: Any = None
        #: the env whose environment state goes into each observation (None: observations as they are)
        self.env = env

    @classmethod
    def start(cls: type[_Controller], session: Any, policy: str, node_cls: type, policy_kwargs: dict[str, Any],
              config: AsyncConfig, *, ready_timeout: float = 600.0) -> _Controller:
        """Serve the policy node over the station's middleware, shaped by the station's first observation."""
        from rio.runtime.manager import ServerManager, connect, serve

        env, mw, st = session.env, session.middleware, session.station
        obs_layout = ObsLayout.of(with_environment(env, env.reset()))
        obs_layout.inputs = _device_rings(session)
        layout = obs_layout.to_dict()
        session.log(f"loading policy '{policy}' ...")
        kwargs = {**policy_kwargs, "observation": layout}
        server = serve(node_cls, mw, name=POLICY_ROLE, **kwargs)
        session.started(session.stack.enter_context(ServerManager([server], station=st.name,
                                                                  ready_timeout=ready_timeout)))
        client = session.stack.enter_context(connect(node_cls, mw, name=POLICY_ROLE, **kwargs))
        meta = PolicyMetadata.from_dict(client.metadata())
        return cls(policy, client, meta, config, env.instruction, env)

    def reset(self, loop: Any) -> None:
        self.inf.restart()
        self.hold = np.asarray(loop.obs.observation.proprio, dtype=np.float64).copy()
        self.phase = loop.phase
        m = self.meta
        loop.say(f"policy '{m.name}': chunks of {m.horizon} x {m.action_dim} at {m.rate_hz:g} Hz; control at "
                 f"{loop.rate_hz:g} Hz" + (f" for {loop.duration:g} s" if loop.duration else " until Ctrl+C"))

    def wait(self, deadline: float) -> bool:
        """Sleep until `deadline`; True as soon as an awaited chunk lands first (the early wake)."""
        inf = self.inf
        while inf.in_flight is not None:
            if inf.arrived():
                return True
            now = clock.now()
            left = deadline - now
            if left <= _POLL_S:
                break
            expected = inf.expected_arrival()
            near = expected is not None and now >= expected - _NEAR_S
            time.sleep(min(_POLL_S if near else _FAR_S, left - _POLL_S))
        clock.precise_wait(deadline)
        return False

    def step(self, tick: Tick) -> np.ndarray | None:
        self.client.check_alive()
        chunk = self.inf.poll(tick.t)
        self.sample = self.inf.command(tick.t_target)
        tick.info.update(sample=self.sample, chunk=chunk)
        return self.sample.action if self.sample is not None else self.hold

    def after(self, tick: Tick) -> None:
        inf = self.inf
        if self.sample is not None:
            inf.applied(self.sample, tick.t_sent)
        if inf.wants_request(tick.t):
            with self.phase("policy request"):
                obs = with_environment(self.env, tick.step) if self.env is not None else tick.step.observation
                inf.request(obs, self.instruction, float(tick.step.meta["t_obs"]), clock.now())

    def done(self) -> str | None:
        return None

    def node_died(self, error: NodeDiedError) -> bool:
        return error.node == POLICY_ROLE  # the policy stopped: the robot holds; any other node: an error

    def finish(self, summary: RunSummary) -> None:
        s = self.inf.stats()
        summary.details.update(policy=self.policy, metadata=self.meta.to_dict(), stats=s)
        summary.lines.append(f"policy '{self.policy}': chunks {s.get('chunks', 0)} of {s.get('requests', 0)} "
                             f"requested; late {s.get('late_events', 0)} times ({s.get('late_ticks', 0)} ticks); "
                             f"{s.get('timeouts', 0)} timeouts")
        for key, label in (("forward_ms_p50", "forward pass"), ("first_action_ms_p50", "obs -> first action"),
                           ("overhead_ms_p50", "overhead"), ("action_age_ms_p50", "action age")):
            if s.get(key) is not None:
                summary.lines.append(f"{label:20s} p50 {s[key]:8.2f} ms")
