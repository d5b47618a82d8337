"""The twist teleop controller: a spacemouse, keyboard or scripted device drives each arm's tool.

Each tick it reads the device(s) (a ring-buffer read, never blocking), switches mode on
`BUTTON_MODE`, integrates the low-pass filtered, speed-limited twist into each arm's end-effector
target and builds the embodiment's action (IK for joint-space arms). It is done on `BUTTON_DONE`
(with `BUTTON_KEEP` / `BUTTON_DISCARD`: the episode's verdict, in the summary), or when a device with
a known length (a script) has run its course. One device (`teleop`) drives every
arm, each in its own base frame; a `teleop2` device, when the station has one, drives `arm2`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..control.filters import LowPassFilter
from ..control.teleop import BUTTON_MODE, ButtonEdges, EpisodeEnd, ModeSwitch, TeleopMode, make_teleop_eef_cmd
from .bindings import ArmBinding, bind_arms, build_action
from .feedback import DeviceFeedback
from .travel import Travel, travel_line

DEVICE_ROLES = ("teleop", "teleop2")


#: The optional running total of a device's own motion (rio.interfaces.teleop): where a device publishes
#: it, a cycle's displacement is its difference, exact however sparse or late its samples.
DISPLACEMENT = "displacement"


class DevicePoll:
    """Reads a teleop device once per control cycle and hands out exactly the device's motion since the
    previous cycle, whenever and however irregularly the loop or the device runs.

    The device's motion since the last sample taken is the difference of its `displacement` where it
    publishes one (a script knows its own motion: exact even across a gap in its samples, such as its
    thread stalled by another holding the GIL), else the trapezoid rule over its samples' timestamps.
    It returns a velocity and the time `h` to integrate it over: normally the device's mean velocity
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
        self.twist_last = np.asarray(s["twist"], dtype=np.float64).copy()
        self.total = np.asarray(s[DISPLACEMENT], dtype=np.float64).copy() if DISPLACEMENT in s else None
        self.held_s = 0.0  # time the held twist was already integrated over, past t_last
        self.held = np.zeros(6)  # ... and the motion that handed out
        self.interval = 0.0  # the device's usual time between samples (median of the recent ones)

    def __call__(self, h: float) -> dict:
        s = self.client.get_state(k=self.k)
        ts = np.asarray(s["timestamp"], dtype=np.float64)
        tw = np.asarray(s["twist"], dtype=np.float64)
        new = ts > self.t_last
        latest = {key: np.asarray(v)[-1] for key, v in s.items()}
        if not new.any():  # no new sample (a device slower than the loop, or late): hold its last twist
            limit = 1.5 * self.interval if self.interval > 0 else float("inf")
            hold = min(h, max(limit - self.held_s, 0.0))
            twist = self.twist_last * (hold / h) if h > 0 else self.twist_last.copy()
            self.held_s += h
            self.held += self.twist_last * hold
            return {"twist": twist, "h": h, "gripper": float(latest["gripper"]),
                    "buttons": np.asarray(latest["buttons"], dtype=bool), "raw": latest}
        if self.total is not None:
            total = np.asarray(s[DISPLACEMENT], dtype=np.float64)[new][-1]
            delta, self.total = total - self.total, total.copy()
        else:
            t_prev, tw_prev, delta = self.t_last, self.twist_last, np.zeros(6)
            for t_i, tw_i in zip(ts[new], tw[new], strict=True):
                delta += 0.5 * (tw_prev + tw_i) * (t_i - t_prev)
                t_prev, tw_prev = t_i, tw_i
        span = float(ts[new][-1] - self.t_last)
        if ts.size > 2:
            self.interval = float(np.median(np.diff(ts)))
        owed = delta - self.held  # the device's motion not handed out yet
        twist, h = _spread(owed, np.maximum(_speeds(delta / span), _speeds(self.twist_last)), span - self.held_s)
        self.t_last, self.twist_last = float(ts[new][-1]), tw[new][-1].copy()
        self.held_s, self.held = 0.0, np.zeros(6)
        buttons = np.any(np.asarray(s["buttons"], dtype=bool)[new], axis=0)
        return {"twist": twist, "h": h, "gripper": float(latest["gripper"]), "buttons": buttons, "raw": latest}


def _speeds(twist: np.ndarray) -> np.ndarray:
    """(linear, angular) speed of a twist."""
    return np.array([np.linalg.norm(twist[:3]), np.linalg.norm(twist[3:])])


def _spread(owed: np.ndarray, speeds: np.ndarray, h_left: float) -> tuple[np.ndarray, float]:
    """A velocity and a time whose product is `owed`: over the time left, or longer where that would
    move a part (linear, angular) faster than `speeds`, the device's own."""
    h = max(h_left, 0.0)
    for part, speed in zip((owed[:3], owed[3:]), speeds, strict=True):
        dist = float(np.linalg.norm(part))
        if dist > 1e-12 and speed > 0:
            h = max(h, dist / speed)
    if h <= 0:
        return np.zeros(6), 0.0
    return owed / h, h


class TwistTeleop:
    """Controller (rio.control.loop): see the module docstring. `devices`: {role: connected client}."""

    name = "teleop"

    def __init__(self, devices: dict[str, Any], *, device: str, mode: str | TeleopMode = TeleopMode.TRANSLATION,
                 max_pos_speed: float = 0.15, max_rot_speed: float = 1.0, filter_hz: float | None = 8.0,
                 visual: Any = None):
        self.devices, self.device, self.visual = devices, device, visual
        self.max_pos_speed, self.max_rot_speed = max_pos_speed, max_rot_speed
        self.filters = {r: LowPassFilter(filter_hz) if filter_hz else None for r in devices}
        self.edges = {r: ButtonEdges() for r in devices}
        self.switch = ModeSwitch(TeleopMode.parse(mode))
        self.end = EpisodeEnd()
        self.arms: list[Any] = []
        self.expected_s = 0.0  # how long the device says its run lasts (a script), 0 when open-ended

    def reset(self, loop: Any) -> None:
        robot = loop.env.robot
        self.body = None
        if "humanoid" in robot.clients:  # its wrists, by IK on its model: the upper body, as two arms
            from .hands import HumanoidWrists

            self.body = HumanoidWrists(robot.clients["humanoid"])
            self.arms = list(self.body.wrists.values())
        else:
            self.arms = bind_arms(robot)
            for b in self.arms:
                b.reset_target()
        self.drive = {b.role: ("teleop2" if b.role == "arm2" and "teleop2" in self.devices else "teleop")
                      for b in self.arms}
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
            lowpass = self.filters[r]
            if lowpass is not None:  # on the span it is integrated over (see LowPassFilter.over)
                p["twist"] = lowpass.over(p["twist"], p["h"])
        before = {b.role: np.array(b.target[:3], dtype=np.float64) for b in self.arms}
        for b in self.arms:
            p = polled[self.drive[b.role]]
            b.target = make_teleop_eef_cmd(b.target, p["twist"], p["h"], self.switch.mode, self.max_pos_speed,
                                           self.max_rot_speed)
            if b.gripper is not None:
                b.gripper_cmd = p["gripper"] * b.max_width
        tick.info.update(devices={r: p["raw"] for r, p in polled.items()}, arms=self.arms, mode=self.switch.mode)
        action = self.body.action(tick.env.robot) if self.body is not None else build_action(tick.env.robot,
                                                                                             self.arms)
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
        self.end.report(summary)
        if self.visual is not None:
            summary.details["viz"] = self.visual.where
            summary.lines.append(f"viz: {self.visual.where}")
            self.visual.close()
