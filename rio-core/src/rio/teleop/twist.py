"""The twist teleop controller: a spacemouse, keyboard or scripted device drives each arm's tool.

Each tick it reads the device(s) (a ring-buffer read, never blocking), switches mode on
`BUTTON_MODE`, integrates the low-pass filtered, speed-limited twist into each arm's end-effector
target and builds the embodiment's action (IK for joint-space arms). It is done on `BUTTON_DONE`
(with `BUTTON_KEEP` / `BUTTON_DISCARD`: the episode's verdict, in the summary), or when a device with
a known length (a script) has run its course. One device (`teleop`) drives every
arm, each in its own base frame; a `teleop2` device, when the station has one, drives `arm2`.

On a mobile manipulator (a `base` role) the mode key also reaches BASE: there the device's x, y and yaw
drive the base's body twist (speed-limited like the tool, then by the base kind's own limits) and the arm
holds; in every arm mode the base is commanded to stand still. A run can start in BASE (`mode = "base"`).

A device that moves several arms apart (the sim's scripted expert) also publishes `twists` (n, 6) and
`grippers` (n,): row i drives the i-th arm the device drives, in role order (arm, arm2), integrated and
filtered exactly as `twist`; `twist` and `gripper` stay its first row, for controllers that read one.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio.control.filters import LowPassFilter
from rio.control.teleop import (
    ARM_MODES,
    BUTTON_MODE,
    ButtonEdges,
    EpisodeEnd,
    ModeSwitch,
    TeleopMode,
    base_twist,
    make_teleop_eef_cmd,
)
from rio.errors import RioError
from rio.teleop.bindings import ArmBinding, bind_arms, build_action
from rio.teleop.feedback import DeviceFeedback
from rio.teleop.travel import Travel, travel_line

DEVICE_ROLES = ("teleop", "teleop2")
#: The rates a device publishes that the loop integrates: one twist, or one per arm.
_RATES = ("twist", "twists")


#: The optional running total of a device's own motion (rio.interfaces.teleop): where a device publishes
#: it, a cycle's displacement is its difference, exact however sparse or late its samples.
DISPLACEMENT = "displacement"


class DevicePoll:
    """Reads a teleop device once per control cycle and hands out exactly the device's motion since the
    previous cycle, whenever and however irregularly the loop or the device runs.

    The device's motion since the last sample taken is the difference of its `displacement` where it
    publishes one (a script knows its own motion: exact even across a gap in its samples, such as its
    thread stalled by another holding the GIL), else the trapezoid rule over its samples' timestamps;
    for each rate it publishes (`twist`, and `twists`: one row per arm, the bimanual expert's).
    It returns velocities and one time `h` to integrate them over: normally the device's mean velocity
    over its samples' span, so a speed limit applied to the velocity never clips the catch-up of a late
    cycle (CI saw a scripted square end 5 mm open after four late ticks when the span was squeezed into
    the cycle). A device slower than the loop has its last twist held meanwhile, for at most 1.5 of its
    usual sample intervals (past that it is late, not slow: the target waits for it rather than guess
    on and come back); that held motion is counted, and the next samples hand out only what remains
    (`owed`), so guessing ahead never adds or loses travel (before, a 100 Hz device silent for 0.5 s
    mid-move moved the target 68 mm of its 100 mm: tests/test_teleop_poll.py; the scripted square ended
    21 mm open after such a stall). Where what remains does not fit in the time left at the device's
    own speed, `h` is stretched rather than the velocity raised past it. Buttons are OR-ed over the
    samples, so a short press is never missed."""

    def __init__(self, client: Any, history: int = 32):
        self.client, self.k = client, int(min(history, getattr(client, "buffer_capacity", 64) or 64))
        s = client.get_state()
        self.t_last = float(s["timestamp"])
        self.rates = [key for key in _RATES if key in s]
        self.last = {key: np.asarray(s[key], dtype=np.float64).copy() for key in self.rates}
        self.total = np.asarray(s[DISPLACEMENT], dtype=np.float64).copy() if DISPLACEMENT in s else None
        self.held_s = 0.0  # time the held twist was already integrated over, past t_last
        self.held = {key: np.zeros_like(v) for key, v in self.last.items()}  # ... and the motion that handed out
        self.interval = 0.0  # the device's usual time between samples (median of the recent ones)

    def __call__(self, h: float) -> dict:
        s = self.client.get_state(k=self.k)
        ts = np.asarray(s["timestamp"], dtype=np.float64)
        new = ts > self.t_last
        latest = {key: np.asarray(v)[-1] for key, v in s.items()}
        out: dict[str, Any] = {}
        if not new.any():  # no new sample (a device slower than the loop, or late): hold its last twist
            limit = 1.5 * self.interval if self.interval > 0 else float("inf")
            hold = min(h, max(limit - self.held_s, 0.0))
            for key in self.rates:
                out[key] = self.last[key] * (hold / h) if h > 0 else self.last[key].copy()
                self.held[key] += self.last[key] * hold
            self.held_s += h
            buttons = np.asarray(latest["buttons"], dtype=bool)
        else:
            span = float(ts[new][-1] - self.t_last)
            if ts.size > 2:
                self.interval = float(np.median(np.diff(ts)))
            owed, h_out = {}, max(span - self.held_s, 0.0)
            for key in self.rates:
                rate = np.asarray(s[key], dtype=np.float64)[new]
                if key == "twist" and self.total is not None:
                    total = np.asarray(s[DISPLACEMENT], dtype=np.float64)[new][-1]
                    delta, self.total = total - self.total, total.copy()
                else:
                    t_prev, prev, delta = self.t_last, self.last[key], np.zeros_like(self.last[key])
                    for t_i, r_i in zip(ts[new], rate, strict=True):
                        delta += 0.5 * (prev + r_i) * (t_i - t_prev)
                        t_prev, prev = t_i, r_i
                owed[key] = delta - self.held[key]  # the device's motion not handed out yet
                speeds = np.maximum(_speeds(delta / span) if span > 0 else 0.0, _speeds(self.last[key]))
                h_out = max(h_out, _needed(owed[key], speeds))
                self.last[key], self.held[key] = rate[-1].copy(), np.zeros_like(self.held[key])
            for key in self.rates:
                out[key] = owed[key] / h_out if h_out > 0 else np.zeros_like(owed[key])
            h, self.t_last, self.held_s = h_out, float(ts[new][-1]), 0.0
            buttons = np.any(np.asarray(s["buttons"], dtype=bool)[new], axis=0)
        out.update(h=h, gripper=float(latest["gripper"]), buttons=buttons, raw=latest)
        if "grippers" in latest:
            out["grippers"] = np.asarray(latest["grippers"], dtype=np.float64)
        return out


def _speeds(twist: np.ndarray) -> np.ndarray:
    """(linear, angular) speed of a twist, or of each row of several."""
    return np.stack([np.linalg.norm(twist[..., :3], axis=-1), np.linalg.norm(twist[..., 3:], axis=-1)], axis=-1)


def _needed(owed: np.ndarray, speeds: np.ndarray) -> float:
    """The time moving `owed` takes at `speeds`, the device's own (linear, angular; per row): no part is
    handed out faster than the device moved it."""
    dist = _speeds(owed)
    ok = (dist > 1e-12) & (np.asarray(speeds) > 0)
    return float(np.max(dist[ok] / np.broadcast_to(speeds, dist.shape)[ok], initial=0.0))


class TwistTeleop:
    """Controller (rio.loop.control_loop): see the module docstring. `devices`: {role: connected client}."""

    name = "teleop"

    def __init__(self, devices: dict[str, Any], *, device: str, mode: str | TeleopMode = TeleopMode.TRANSLATION,
                 max_pos_speed: float = 0.15, max_rot_speed: float = 1.0, filter_hz: float | None = 8.0,
                 visual: Any = None):
        self.devices, self.device, self.visual = devices, device, visual
        self.max_pos_speed, self.max_rot_speed = max_pos_speed, max_rot_speed
        self.filters = {(r, key): LowPassFilter(filter_hz) for r in devices for key in _RATES} if filter_hz else {}
        self.edges = {r: ButtonEdges() for r in devices}
        self.switch = ModeSwitch(TeleopMode.parse(mode), modes=tuple(TeleopMode))
        self.end = EpisodeEnd()
        self.arms: list[Any] = []
        self.expected_s = 0.0  # how long the device says its run lasts (a script), 0 when open-ended

    def reset(self, loop: Any) -> None:
        robot = loop.env.robot
        self.body = None
        if "humanoid" in robot.clients:  # its wrists, by IK on its model: the upper body, as two arms
            from rio.teleop.hands import HumanoidWrists

            self.body = HumanoidWrists(robot.clients["humanoid"])
            self.arms = list(self.body.wrists.values())
        else:
            self.arms = bind_arms(robot)
            for b in self.arms:
                b.reset_target()
        self.has_base = "base" in robot.clients
        if not self.has_base:
            self.switch.modes = ARM_MODES
            if self.switch.mode == TeleopMode.BASE:
                raise RioError(f"teleop mode 'base' drives a mobile base; embodiment '{robot.name}' has none")
        self.base_twist = None if not self.has_base else np.zeros(3)
        self.base = robot.clients.get("base")
        self.drive = {b.role: ("teleop2" if b.role == "arm2" and "teleop2" in self.devices else "teleop")
                      for b in self.arms}
        self.row = {b.role: [b2.role for b2 in self.arms if self.drive[b2.role] == self.drive[b.role]].index(b.role)
                    for b in self.arms}  # which of its device's `twists` rows drives the arm
        self.polls = {r: DevicePoll(dev) for r, dev in self.devices.items()}
        self.travel = {f"device '{r}'": Travel() for r in self.devices}  # what each stage moved (travel.py)
        self.travel.update({f"{b.role} target": Travel() for b in self.arms})
        for lowpass in self.filters.values():  # every run starts from rest
            if lowpass is not None:
                lowpass.reset()
        self.feedback = DeviceFeedback(self.devices, log=loop.say)
        for dev in self.devices.values():  # optional device API, looked up by name
            if "reset" in dir(dev):
                self.expected_s = max(self.expected_s, float(dev.reset() or 0.0))
            if "help" in dir(dev):
                loop.say(dev.help())
        self.t_prev: float | None = None
        if loop.duration is None and self.expected_s > 0:  # a script: its length, with room to finish
            loop.duration = self.expected_s + 10.0
        loop.say(f"teleop running: {self.device}, mode {self.switch.mode.name.lower()}, {loop.rate_hz:g} Hz"
                 + (f", up to {loop.duration:.0f} s" if loop.duration else ", until the device finishes or Ctrl+C"))

    def step(self, tick: Any) -> np.ndarray:
        h = 0.0 if self.t_prev is None else max(tick.t - self.t_prev, 0.0)
        self.t_prev = tick.t
        polled = {r: poll(h) for r, poll in self.polls.items()}
        for r, p in polled.items():
            self.travel[f"device '{r}'"].add(p["twist"][:3] * p["h"])
            pressed = self.edges[r](p["buttons"])
            self.end.update(p["buttons"])
            if r == "teleop":
                self.switch.update(bool(pressed.size > BUTTON_MODE and pressed[BUTTON_MODE]), tick.t)
            for key in _RATES:
                lowpass = self.filters.get((r, key))
                if lowpass is not None and key in p:  # on the span it is integrated over (see LowPassFilter.over)
                    p[key] = lowpass.over(p[key], p["h"])
        before = {b.role: np.array(b.target[:3], dtype=np.float64) for b in self.arms}
        for b in self.arms:
            p, i = polled[self.drive[b.role]], self.row[b.role]
            twists, grippers = p.get("twists"), p.get("grippers")
            twist = twists[i] if twists is not None and i < len(twists) else p["twist"]
            b.target = make_teleop_eef_cmd(b.target, twist, p["h"], self.switch.mode, self.max_pos_speed,
                                           self.max_rot_speed)
            if b.gripper is not None:
                grip = grippers[i] if grippers is not None and i < len(grippers) else p["gripper"]
                b.gripper_cmd = float(grip) * b.max_width
        if self.has_base:  # the main device drives the base in BASE mode, else the base stands still
            self.base_twist = base_twist(polled["teleop"]["twist"], self.switch.mode, self.max_pos_speed,
                                         self.max_rot_speed)
        tick.info.update(devices={r: p["raw"] for r, p in polled.items()}, arms=self.arms, mode=self.switch.mode)
        action = self.body.action(tick.env.robot) if self.body is not None else build_action(
            tick.env.robot, self.arms, base_twist=self.base_twist)
        for b in self.arms:  # after the action: IK may have pulled an unreachable target back
            self.travel[f"{b.role} target"].add(np.asarray(b.target[:3]) - before[b.role])
        return action

    def after(self, tick: Any) -> None:
        measured = [b for b in self.arms if isinstance(b, ArmBinding)]  # a humanoid's wrists: targets only
        self.feedback(tick.t, measured)
        if self.visual is not None:
            self.visual.log(tick.t - tick.t0, tick.it, tick.step, measured)

    def done(self) -> str | None:
        return self.end.reason()

    def finish(self, summary: Any) -> None:
        summary.details["device"] = self.device
        summary.details["mode"] = self.switch.mode.name.lower()
        summary.details["travel"] = {name: t.report() for name, t in self.travel.items()}
        summary.lines.append(travel_line(self.travel))
        if self.base is not None:  # where the base went, by its odometry
            x, y, th = (float(v) for v in self.base.get_state()["odom_pose"])
            summary.details["base_odometry"] = [round(x, 4), round(y, 4), round(th, 4)]
            summary.lines.append(f"base: odometry ({x:+.3f}, {y:+.3f}) m, heading {np.degrees(th):+.1f} deg")
        self.end.report(summary)
        if self.visual is not None:
            summary.details["viz"] = self.visual.where
            summary.lines.append(f"viz: {self.visual.where}")
            self.visual.close()
