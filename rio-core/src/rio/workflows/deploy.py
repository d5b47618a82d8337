"""`run_deploy`: a policy on a station, on the one control loop (`rio.policy.deploy.PolicyController`).

The station is resolved here, its policy component taken out of the nodes the station starts (the
controller starts the policy node itself, so it can wait for the model to load), and an optional teleop
device swapped in for a policy commanded by one.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rio.loop.control_loop import Tick
from rio.loop.summary import RunSummary
from rio.policy.async_inference import AsyncConfig
from rio.policy.deploy import POLICY_ROLE, PolicyController

#: How long a policy node may take to load its model and be ready, unless told otherwise.
POLICY_READY_S = 600.0


def run_deploy(station: Any, policy: str | None = None, *, instruction: str | None = None,
               record: str | None = None, duration: float | None = None, middleware: str | None = None,
               rate_hz: float | None = None, config: AsyncConfig | None = None,
               on_tick: Callable[[Tick], None] | None = None, log: Callable[[str], None] | None = print,
               ready_timeout: float | None = None, profile: str | None = None, registry: Any = None,
               device: str | None = None, device_config: dict | None = None, seed: int | None = None,
               episode: int | None = None, status: bool = False) -> RunSummary:
    """Run `policy` (a `--policy` SPEC; default: the station's policy component) on `station`
    (registered name, .toml path or `Station`) until `duration` seconds pass or a stop signal.
    Each tick's `info` holds the schedule's `sample` (None while holding) and the `chunk` that landed.
    `device` (+ `device_config`): the station's `teleop` component, replaced or added, for a policy that
    reads a device (`onnx.locomotion`'s `command_from`). `seed`, `episode`: the task's episode on a station
    that runs one (`run_workflow`). `ready_timeout`: seconds the nodes may take to be ready, the policy
    node's model load included (default: the station's `ready_timeout_s` for its nodes, 600 s for the policy)."""
    from rio.policy.resolve import resolve_policy
    from rio.station.edit import without_role
    from rio.workflows.run import run_workflow
    from rio.workflows.teleop import prepare_station

    st = prepare_station(station, device, device_config, registry=registry)
    name, node_cls, policy_kwargs = resolve_policy(policy, st, registry)

    def make(session: Any) -> PolicyController:
        return PolicyController.start(session, name, node_cls, policy_kwargs, config or AsyncConfig(),
                                      ready_timeout=ready_timeout or POLICY_READY_S)

    return run_workflow(without_role(st, POLICY_ROLE), make, middleware=middleware, rate_hz=rate_hz, duration=duration,
                        instruction=instruction, record=record, on_tick=on_tick, profile=profile,
                        registry=registry, log=log, seed=seed, episode=episode, ready_timeout=ready_timeout,
                        status=status)
