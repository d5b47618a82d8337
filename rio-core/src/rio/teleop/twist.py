"""The twist teleop controller: a spacemouse, keyboard or scripted device drives each arm's tool.

Each tick it reads the device(s) (a ring-buffer read, never blocking), switches mode on
`BUTTON_MODE`, integrates the low-pass filtered, speed-limited twist into each arm's end-effector
target and builds the embodiment's action (IK for joint-space arms). It is done on `BUTTON_DONE`
(with `BUTTON_KEEP` / `BUTTON_DISCARD`: the episode's verdict, in the summary), or when a device with
a known length (a script) has run its course. One device (`teleop`) drives every
arm, each in its own base frame; a `teleop2` device, when the station has one, drives `arm2`.

A device that moves several arms apart (the sim's scripted expert) also publishes `twists` (n, 6) and
`grippers` (n,): row i drives the i-th arm the device drives, in role order (arm, arm2), integrated and
filtered exactly as `twist`; `twist` and `gripper` stay its first row, for controllers that read one.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio.control.filters import LowPassFilter
from rio.control.teleop import BUTTON_MODE, ButtonEdges, EpisodeEnd, ModeSwitch, TeleopMode, make_teleop_eef_cmd
from rio.teleop.bindings import ArmBinding, bind_arms, build_action
from rio.teleop.feedback import DeviceFeedback

DEVICE_ROLES = ("teleop", "teleop2")
#: The rates a device publishes that the loop integrates: one twist, or one per arm.
_RATES = ("twist", "twists")


class DevicePoll:
    """Reads a teleop device once per control cycle and integrates its twist over the device's own
    samples since the previous cycle (trapezoid rule on their timestamps), so the displacement does
    not depend on when, or how regularly, the loop happens to sample: a late cycle loses nothing.
    It returns the device's mean velocity over those samples and the time `h` to integrate it over
    (their span), so a speed limit applied to the velocity never clips the catch-up of a late cycle
    (CI saw a scripted square end 5 mm open after four late ticks when the span was squeezed into
    the cycle). A device slower than the loop has its last twist held meanwhile; that time is not
    integrated twice when its next sample arrives. Buttons are OR-ed over the samples, so a short
    press is never missed."""

    def __init__(self, client: Any, history: int = 32):
        self.client, self.k = client, int(min(history, getattr(client, "buffer_capacity", 64) or 64))
        s = client.get_state()
        self.t_last = float(s["timestamp"])
        self.rates = [key for key in _RATES if key in s]
        self.last = {key: np.asarray(s[key], dtype=np.float64).copy() for key in self.rates}
        self.held_s = 0.0  # time the held twist was already integrated over, past t_last

    def __call__(self, h: float) -> dict:
        s = self.client.get_state(k=self.k)
        ts = np.asarray(s["timestamp"], dtype=np.float64)
        new = ts > self.t_last
        latest = {key: np.asarray(v)[-1] for key, v in s.items()}
        out: dict[str, Any] = {}
        if new.any():
            span = float(ts[new][-1] - self.t_last)
            for key in self.rates:
                rate = np.asarray(s[key], dtype=np.float64)[new]
                t_prev, prev, delta = self.t_last, self.last[key], np.zeros_like(self.last[key])
                for t_i, r_i in zip(ts[new], rate, strict=True):
                    delta += 0.5 * (prev + r_i) * (t_i - t_prev)
                    t_prev, prev = t_i, r_i
                self.last[key] = prev
                out[key] = delta / span if span > 0 else prev.copy()
            self.t_last = float(ts[new][-1])
            buttons = np.any(np.asarray(s["buttons"], dtype=bool)[new], axis=0)
            h, self.held_s = max(span - self.held_s, 0.0), 0.0
        else:  # no new sample (a device slower than the loop): hold its last twist
            out.update({key: self.last[key].copy() for key in self.rates})
            buttons = np.asarray(latest["buttons"], dtype=bool)
            self.held_s += h
        out.update(h=h, gripper=float(latest["gripper"]), buttons=buttons, raw=latest)
        if "grippers" in latest:
            out["grippers"] = np.asarray(latest["grippers"], dtype=np.float64)
        return out


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
        self.switch = ModeSwitch(TeleopMode.parse(mode))
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
        self.drive = {b.role: ("teleop2" if b.role == "arm2" and "teleop2" in self.devices else "teleop")
                      for b in self.arms}
        self.row = {b.role: [b2.role for b2 in self.arms if self.drive[b2.role] == self.drive[b.role]].index(b.role)
                    for b in self.arms}  # which of its device's `twists` rows drives the arm
        self.polls = {r: DevicePoll(dev) for r, dev in self.devices.items()}
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
            pressed = self.edges[r](p["buttons"])
            self.end.update(p["buttons"])
            if r == "teleop":
                self.switch.update(bool(pressed.size > BUTTON_MODE and pressed[BUTTON_MODE]), tick.t)
            for key in _RATES:
                lowpass = self.filters.get((r, key))
                if lowpass is not None and key in p:  # on the span it is integrated over (see LowPassFilter.over)
                    p[key] = lowpass.over(p[key], p["h"])
        for b in self.arms:
            p, i = polled[self.drive[b.role]], self.row[b.role]
            twists, grippers = p.get("twists"), p.get("grippers")
            twist = twists[i] if twists is not None and i < len(twists) else p["twist"]
            b.target = make_teleop_eef_cmd(b.target, twist, p["h"], self.switch.mode, self.max_pos_speed,
                                           self.max_rot_speed)
            if b.gripper is not None:
                grip = grippers[i] if grippers is not None and i < len(grippers) else p["gripper"]
                b.gripper_cmd = float(grip) * b.max_width
        tick.info.update(devices={r: p["raw"] for r, p in polled.items()}, arms=self.arms, mode=self.switch.mode)
        if self.body is not None:
            return self.body.action(tick.env.robot)
        return build_action(tick.env.robot, self.arms)

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
        self.end.report(summary)
        if self.visual is not None:
            summary.details["viz"] = self.visual.where
            summary.lines.append(f"viz: {self.visual.where}")
            self.visual.close()
