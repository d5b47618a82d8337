"""`run_teleop`: teleoperate any station — one arm or two, joint or end-effector action spaces,
simulated or real, any middleware — on the one control loop (`rio.loop.control_loop`).

A twist device (keyboard, spacemouse, scripted) drives each arm's tool (`rio.teleop.twist`); a
leader arm is mirrored joint by joint (`rio.teleop.leader_follower`); a hand tracker's wrists and
fingers are retargeted onto arms, a humanoid's wrists and dexterous hands (`rio.teleop.hands`).
Either way the run ends on the device's done button, after `duration` seconds, or on a stop signal,
and returns a `RunSummary`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rio.errors import RioError
from rio.loop.control_loop import Tick
from rio.loop.summary import RunSummary
from rio.station.model import Station


def _device_is(station: Station, flag: str) -> bool:
    comp = station.components.get("teleop")
    return comp is not None and bool(getattr(comp.node_class(), flag, False))


def drives_leader_arm(station: Station) -> bool:
    """True when the station's teleop device is a leader arm (`TeleopNode.leader_arm`)."""
    return _device_is(station, "leader_arm")


def tracks_hands(station: Station) -> bool:
    """True when the station's teleop device is a hand tracker (`TeleopNode.hand_tracker`)."""
    return _device_is(station, "hand_tracker")


def prepare_station(station: Any, device: str | None = None, device_config: dict | None = None,
                    registry: Any = None) -> Station:
    """The station (name, path or `Station`), validated once, with its `teleop` component replaced by `device`
    and/or configured by `device_config` (`rio.station.edit.with_teleop`)."""
    from rio.station.edit import with_teleop
    from rio.station.load import load_station

    return with_teleop(load_station(station, registry=registry), device, device_config, registry=registry)


def run_teleop(station: Any, device: str | None = None, *, instruction: str | None = None, viz: bool | str = False,
               duration: float | None = None, middleware: str | None = None, rate_hz: float | None = None,
               mode: str | None = None, hand: str = "right", scale: float = 1.0, max_pos_speed: float = 0.15,
               max_rot_speed: float = 1.0, filter_hz: float | None = 8.0, device_config: dict | None = None,
               align_speed: float = 0.5, record: str | None = None, recorder: Any = None, profile: str | None = None,
               on_tick: Callable[[Tick], None] | None = None,
               log: Callable[[str], None] | None = print, seed: int | None = None,
               episode: int | None = None, ready_timeout: float | None = None, status: bool = False,
               home_speed: float | None = None) -> RunSummary:
    """Teleoperate `station` (registered name or .toml path) with `device` (default: the station's
    own `teleop` component). `viz=True` streams to rerun (a string: save to that .rrd file).
    `record`: a dataset directory to record the run into; `recorder`: an open Recorder instead.
    `mode`: translation (twist devices' default), translation_rotation (hand trackers' default), ...;
    hand trackers: `hand` drives a single arm, `scale` multiplies wrist motion. `seed`, `episode`: the
    task's episode on a station that runs one (`run_workflow`). A twist device may name the mode it drives
    in (`default_mode`, the scripted expert: translation_rotation); `mode` overrides it. `home_speed`: move
    every joint device to its home pose at this speed (rad/s) before the run (`rio.workflows.home`)."""
    from rio.workflows.run import run_workflow

    st = prepare_station(station, device, device_config)
    make = teleop_controller(st, viz=viz, mode=mode, hand=hand, scale=scale, max_pos_speed=max_pos_speed,
                             max_rot_speed=max_rot_speed, filter_hz=filter_hz, align_speed=align_speed)
    return run_workflow(st, make, middleware=middleware, rate_hz=rate_hz, duration=duration, instruction=instruction,
                        record=record, recorder=recorder, on_tick=on_tick, profile=profile, log=log, seed=seed,
                        episode=episode, ready_timeout=ready_timeout, status=status, home_speed=home_speed)


def teleop_controller(st: Station, *, viz: bool | str = False, mode: str | None = None, hand: str = "right",
                      scale: float = 1.0, max_pos_speed: float = 0.15, max_rot_speed: float = 1.0,
                      filter_hz: float | None = 8.0, align_speed: float = 0.5) -> Callable[[Any], Any]:
    """The factory of the teleop controller for `st` (its device decides which: leader arm, hand tracker,
    twist device), called with the session once the station runs."""
    from rio.teleop.hands import HandTeleop
    from rio.teleop.leader_follower import LeaderFollower
    from rio.teleop.twist import DEVICE_ROLES, TwistTeleop

    if "teleop" not in st.components:
        raise RioError(f"station '{st.name}' has no teleop component; pass a device (--teleop keyboard or scripted)")

    def make(session: Any) -> Any:
        if drives_leader_arm(st):  # absolute joints from a leader arm: mirrored, not integrated as a twist
            return LeaderFollower.connect(session, align_speed=align_speed)
        if tracks_hands(st):  # absolute wrist poses and finger keypoints: retargeted
            tracker = session.stack.enter_context(session.clients["teleop"]())
            return HandTeleop(tracker, name=st.components["teleop"].driver, hand=hand,
                              mode=mode or "translation_rotation", max_pos_speed=max_pos_speed,
                              max_rot_speed=max_rot_speed, scale=scale)
        devices = {r: session.stack.enter_context(session.clients[r]()) for r in DEVICE_ROLES if r in session.clients}
        visual = None
        if viz:
            from rio.viz import make_viz

            visual = make_viz(st.name, viz if isinstance(viz, str) else None, warn=session.log)
        default = getattr(st.components["teleop"].node_class(), "default_mode", None) or "translation"
        return TwistTeleop(devices, device=st.components["teleop"].driver, mode=mode or default,
                           max_pos_speed=max_pos_speed, max_rot_speed=max_rot_speed, filter_hz=filter_hz,
                           visual=visual)

    return make


def record_teleop(station: Any, recorder: Any, decide: Callable[[RunSummary, Any, Any], tuple[str, bool]],
                  device: str | None = None, *, device_config: dict | None = None, viz: bool | str = False,
                  mode: str | None = None, hand: str = "right", scale: float = 1.0, max_pos_speed: float = 0.15,
                  max_rot_speed: float = 1.0, filter_hz: float | None = 8.0, align_speed: float = 0.5,
                  **session: Any) -> RunSummary:
    """Teleoperate `station` for a recording session: episodes into the open `recorder` until it has its
    count, one station session throughout (`rio.workflows.record_session`: `decide`, `home_speed`, `reset_s`,
    and `run_teleop`'s middleware, rate_hz, duration, instruction, profile, log, seed, ready_timeout, status)."""
    from rio.workflows.record_session import record_session

    st = prepare_station(station, device, device_config)
    make = teleop_controller(st, viz=viz, mode=mode, hand=hand, scale=scale, max_pos_speed=max_pos_speed,
                             max_rot_speed=max_rot_speed, filter_hz=filter_hz, align_speed=align_speed)
    return record_session(st, make, recorder, decide, **session)
