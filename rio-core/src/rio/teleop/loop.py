"""`run_teleop`: the RIO paper's main loop (its appendix figure) as a function, written once against
`Env` and node clients, so it drives any station: one arm or two, joint or end-effector action
spaces, simulated or real, any middleware.

Each cycle of `1 / rate_hz` seconds: wait until mid-cycle, sample the teleop device(s) (a ring
buffer read, never blocking), switch mode on `BUTTON_MODE`, integrate the low-pass filtered,
speed-limited twist into each arm's end-effector target, build the embodiment's action (IK for
joint-space arms) and `env.step()` it with the target time one cycle after this one ends, so the
drivers interpolate smoothly between commands. The run ends on `BUTTON_DONE`, after `duration`
seconds, or on Ctrl+C, and returns a `TeleopSummary`.

One device (`teleop`) drives every arm, each in its own base frame; a `teleop2` device, when the
station has one, drives `arm2`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import clock
from ..control.filters import LowPassFilter
from ..control.teleop import BUTTON_DONE, BUTTON_MODE, ButtonEdges, ModeSwitch, TeleopMode, make_teleop_eef_cmd
from ..errors import RioError
from .bindings import ArmBinding, bind_arms, build_action
from .summary import ArmReport, ObjectReport, TeleopSummary

if TYPE_CHECKING:
    from .leader_follower import LeaderFollowerTick

DEVICE_ROLES = ("teleop", "teleop2")


@dataclass
class TeleopTick:
    """Handed to `on_step` every cycle (tests, recorders, custom displays)."""

    t: float
    it: int
    step: Any
    devices: dict[str, dict]
    arms: list[ArmBinding]
    mode: TeleopMode
    extras: dict[str, Any]
    env: Any = None


def resolve_device(name: str, registry: Any = None) -> str:
    """'scripted' -> 'teleop.scripted' when that is a registered teleop driver; names with a dot as given."""
    if "." in name:
        return name
    from ..plugins import get_registry

    reg = registry or get_registry()
    teleops = {s.name for s in reg.specs("rio_drivers") if s.kind == "teleop"}
    return f"teleop.{name}" if f"teleop.{name}" in teleops else name


def drives_leader_arm(station: Any) -> bool:
    """True when the station's teleop device is a leader arm (`TeleopNode.leader_arm`)."""
    from ..plugins import get_registry

    comp = station.components.get("teleop")
    if comp is None:
        return False
    return bool(getattr(get_registry().find("rio_drivers", comp.driver, "teleop").load(), "leader_arm", False))


def prepare_station(station: Any, device: str | None = None, device_config: dict | None = None):
    """The station, with its `teleop` component replaced by `device` (plus `device_config`)."""
    from ..station.load import load_station, parse_station, read_station_text
    from ..station.model import Station
    from ..station.toml import parse_toml

    if device is None and not device_config:
        return load_station(station)
    if isinstance(station, Station):
        raise RioError("pass the station's name or path (not a Station) to replace its teleop device")
    text, source = read_station_text(station)
    data = parse_toml(text, source)
    comps = data.setdefault("components", {})
    old = comps.get("teleop", {})
    driver = resolve_device(device) if device else old.get("driver")
    if driver is None:
        raise RioError(f"{source}: no teleop component; pass a device (--teleop keyboard or --teleop scripted)")
    keep = old if driver == old.get("driver") else {}
    comps["teleop"] = {**keep, **(device_config or {}), "driver": driver}
    return parse_station(data, source=source)


class DevicePoll:
    """Reads a teleop device once per control cycle and integrates its twist over the device's own
    samples since the previous cycle (trapezoid rule on their timestamps), so the displacement does
    not depend on when, or how regularly, the loop happens to sample: a late cycle loses nothing.
    Buttons are OR-ed over those samples, so a short press is never missed."""

    def __init__(self, client: Any, history: int = 32):
        self.client, self.k = client, int(min(history, getattr(client, "buffer_capacity", 64) or 64))
        s = client.get_state()
        self.t_last = float(s["timestamp"])
        self.twist_last = np.asarray(s["twist"], dtype=np.float64).copy()

    def __call__(self, h: float) -> dict:
        s = self.client.get_state(k=self.k)
        ts = np.asarray(s["timestamp"], dtype=np.float64)
        tw = np.asarray(s["twist"], dtype=np.float64)
        new = ts > self.t_last
        latest = {key: np.asarray(v)[-1] for key, v in s.items()}
        if new.any():
            t_prev, tw_prev, delta = self.t_last, self.twist_last, np.zeros(6)
            for t_i, tw_i in zip(ts[new], tw[new], strict=True):
                delta += 0.5 * (tw_prev + tw_i) * (t_i - t_prev)
                t_prev, tw_prev = t_i, tw_i
            span = t_prev - self.t_last
            self.t_last, self.twist_last = t_prev, tw_prev
            twist = delta / span if span > 0 else tw_prev
            buttons = np.any(np.asarray(s["buttons"], dtype=bool)[new], axis=0)
            # the device's displacement over `span`, spread over this cycle's `h`
            twist = twist * (span / h) if h > 0 else twist
        else:  # no new sample (a device slower than the loop): hold its last twist
            twist, buttons = self.twist_last.copy(), np.asarray(latest["buttons"], dtype=bool)
        return {"twist": twist, "gripper": float(latest["gripper"]), "buttons": buttons, "raw": latest}


def run_teleop(station: Any, device: str | None = None, *, instruction: str | None = None, viz: bool | str = False,
               duration: float | None = None, middleware: str | None = None, rate_hz: float | None = None,
               mode: str | TeleopMode = TeleopMode.TRANSLATION, max_pos_speed: float = 0.15,
               max_rot_speed: float = 1.0, filter_hz: float | None = 8.0, device_config: dict | None = None,
               on_step: Callable[[TeleopTick | LeaderFollowerTick], None] | None = None,
               log: Callable[[str], None] | None = print) -> Any:
    """Teleoperate `station` (registered name or .toml path) with `device` (default: the station's
    own `teleop` component). `viz=True` streams to rerun (a string: save to that .rrd file).

    A twist device (keyboard, spacemouse, scripted) is integrated in end-effector space and returns a
    TeleopSummary; a leader arm is mirrored joint by joint (rio.teleop.leader_follower) and returns
    its LeaderFollowerSummary. Both have `.format()`, and `on_step` gets each cycle's tick (with `.it`,
    `.step` and `.env`) either way."""
    from ..manager import ServerManager
    from ..station.build import make_station
    from ..station.roles import kind_of

    say = log or (lambda _msg: None)
    st = prepare_station(station, device, device_config)
    if "teleop" not in st.components:
        raise RioError(f"station '{st.name}' has no teleop component; pass a device (--teleop keyboard or scripted)")
    if drives_leader_arm(st):  # absolute joints from a leader arm: mirrored, not integrated as a twist
        from .leader_follower import run as run_leader_follower

        return run_leader_follower(st, duration=duration, rate_hz=rate_hz, middleware=middleware,
                                   instruction=instruction, on_step=on_step, log=log)
    servers, clients, env = make_station(st, middleware=middleware)
    if env is None:
        raise RioError(f"station '{st.name}' has no arm or humanoid to teleoperate (roles: {sorted(st.roles())})")
    freq = float(rate_hz or st.rate_hz)
    dt = 1.0 / freq
    summary = TeleopSummary(st.name, st.components["teleop"].driver, "", rate_hz=freq, instruction=instruction)
    say(f"starting station '{st.name}' ({len(servers)} nodes over {clients['teleop'].mw.name}) ...")
    with ServerManager(servers, station=st.name), contextlib.ExitStack() as stack:
        stack.enter_context(env)
        env.instruction = instruction
        # teleop devices of any driver: their optional API (reset, help) is looked up with dir() below
        devices: dict[str, Any] = {r: stack.enter_context(clients[r]()) for r in DEVICE_ROLES if r in clients}
        extras = {r: stack.enter_context(clients[r]()) for r in clients if kind_of(r) == "sensor"}
        arms = bind_arms(env.robot)
        for b in arms:
            b.reset_target()
        drive = {b.role: ("teleop2" if b.role == "arm2" and "teleop2" in devices else "teleop") for b in arms}
        visual = None
        if viz:
            from .viz import make_viz

            visual = make_viz(st.name, viz if isinstance(viz, str) else None, warn=say)
            summary.viz = visual.where if visual else None
        objects = _ObjectWatch(extras)
        paths = {b.role: 0.0 for b in arms}
        last_tool = {b.role: b.start_pose[:3].copy() for b in arms}
        polls = {r: DevicePoll(dev) for r, dev in devices.items()}
        filters = {r: LowPassFilter(filter_hz) if filter_hz else None for r in devices}
        edges = {r: ButtonEdges() for r in devices}
        switch = ModeSwitch(TeleopMode.parse(mode))
        expected = 0.0
        for dev in devices.values():
            if "reset" in dir(dev):
                expected = max(expected, float(dev.reset() or 0.0))
            if "help" in dir(dev):
                say(dev.help())
        limit = duration if duration is not None else (expected + 10.0 if expected > 0 else None)
        say(f"teleop running: {summary.device}, mode {switch.mode.name.lower()}, {freq:g} Hz"
            + (f", up to {limit:.0f} s" if limit else ", until the device finishes or Ctrl+C"))

        t_start = clock.now()
        env.set_start_time(t_start)
        it, t_prev = 0, t_start
        summary.reason = "duration reached"
        try:
            while True:
                t_cycle_end = t_start + (it + 1) * dt
                t_sample = t_cycle_end - dt / 2
                clock.precise_wait(t_sample)
                h = max(t_sample - t_prev, 0.0)
                t_prev = t_sample
                polled = {r: poll(h) for r, poll in polls.items()}
                done = False
                for r, p in polled.items():
                    pressed = edges[r](p["buttons"])
                    done |= bool(p["buttons"].size > BUTTON_DONE and p["buttons"][BUTTON_DONE])
                    if r == "teleop":
                        switch.update(bool(pressed.size > BUTTON_MODE and pressed[BUTTON_MODE]), t_sample)
                    lowpass = filters[r]
                    if lowpass is not None:
                        p["twist"] = lowpass(p["twist"], t_sample)
                for b in arms:
                    p = polled[drive[b.role]]
                    b.target = make_teleop_eef_cmd(b.target, p["twist"], h, switch.mode, max_pos_speed, max_rot_speed)
                    if b.gripper is not None:
                        b.gripper_cmd = p["gripper"] * b.max_width
                action = build_action(env.robot, arms)
                step = env.step(action, t_cmd_target=t_cycle_end + dt)
                objects.update()
                for b in arms:
                    tool = np.asarray(b.client.get_state()["eef_pose"][:3], dtype=np.float64)
                    paths[b.role] += float(np.linalg.norm(tool - last_tool[b.role]))
                    last_tool[b.role] = tool
                if on_step is not None:
                    on_step(TeleopTick(t_sample, it, step, {r: p["raw"] for r, p in polled.items()}, arms,
                                       switch.mode, extras, env))
                if visual is not None:
                    visual.log(t_sample - t_start, it, step, arms)
                it += 1
                late = clock.now() - t_cycle_end
                if late > 0:
                    summary.late_ticks += 1
                    summary.max_late_ms = max(summary.max_late_ms, late * 1000)
                    if late > dt:  # fell behind by a whole cycle: re-anchor instead of bursting
                        it = int((clock.now() - t_start) / dt)
                clock.precise_wait(t_cycle_end)
                summary.ticks += 1
                if done:
                    summary.reason = "the device finished"
                    break
                if limit is not None and clock.now() - t_start >= limit:
                    break
        except KeyboardInterrupt:
            summary.reason = "interrupted (Ctrl+C)"
        summary.seconds = clock.now() - t_start
        _settle(arms, dt)
        for b in arms:
            s = b.client.get_state()
            g = None if b.gripper is None else float(b.gripper.get_state()["position"])
            summary.arms.append(ArmReport(b.role, b.start_pose, np.asarray(s["eef_pose"]).copy(), b.target.copy(),
                                          paths[b.role], g))
        summary.objects = objects.report()
        if visual is not None:
            visual.close()
    return summary


def _settle(arms: list[ArmBinding], dt: float) -> None:
    """Let the arms arrive at their last targets (their commands end a cycle ahead) before reporting."""
    clock.precise_wait(clock.now() + 3 * dt)


class _ObjectWatch:
    """Ground-truth object poses from any sensor node that names objects (a simulator's world)."""

    def __init__(self, extras: dict[str, Any]):
        self.sources = [(c, list(c.object_names())) for c in extras.values() if "object_names" in dir(c)]
        self.start: dict[str, np.ndarray] = {}
        self.max_z: dict[str, float] = {}
        self.last: dict[str, np.ndarray] = {}
        self.update()
        self.start = {k: v.copy() for k, v in self.last.items()}

    def update(self) -> None:
        for client, names in self.sources:
            poses = np.asarray(client.get_state()["object_poses"])
            for name, pose in zip(names, poses[:len(names)], strict=True):
                self.last[name] = pose.copy()
                self.max_z[name] = max(self.max_z.get(name, -np.inf), float(pose[2]))

    def report(self) -> list[ObjectReport]:
        self.update()
        return [ObjectReport(n, self.start[n], self.last[n], self.max_z[n]) for n in self.start]
