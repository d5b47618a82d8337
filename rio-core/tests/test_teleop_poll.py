"""How teleop turns a device's samples into the target's motion (rio.teleop.twist.DevicePoll, the low-pass it
feeds, the scripted device's own running total): the target moves exactly as far as the device did, however
irregular the loop's cycles and the device's samples, including a device stalled for a while mid-move.
Device and loop are simulated here (explicit times), so every figure is exact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rio.control.filters import LowPassFilter
from rio.teleop.scripted import ScriptedTeleop, bump, bump_integral
from rio.teleop.twist import DevicePoll


class Device:
    """A device's ring buffer as a client sees it: the samples published so far, each with its time."""

    def __init__(self, running_total: bool):
        self.running_total = running_total
        self.samples: list[dict] = []

    def publish(self, t: float, twist, moved) -> None:
        s = {"timestamp": t, "twist": np.asarray(twist, float), "gripper": 1.0, "buttons": np.zeros(2, bool)}
        if self.running_total:
            s["displacement"] = np.asarray(moved, float)
        self.samples.append(s)

    def get_state(self, k: int | None = None) -> dict:
        rows = self.samples[-(k or 1):]
        if k is None:
            return dict(rows[-1])
        return {key: np.array([r[key] for r in rows]) for key in rows[-1]}


def move(t: float) -> float:
    """A 0.1 m raised-cosine move along x from 0.2 s to 1.2 s (the scripted device's profile)."""
    return 0.1 * bump_integral(t - 0.2, 1.0)


def speed(t: float) -> float:
    return 0.1 * bump(t - 0.2, 1.0) if 0.2 <= t <= 1.2 else 0.0


def run(device: Device, device_times, loop_times, lowpass: bool = False) -> tuple[float, float, float]:
    """The device publishes at `device_times`, the loop polls at `loop_times`; returns how far the target
    moved along x, its fastest speed and the most it ever moved back (the device only goes forward)."""
    pending = sorted(device_times)
    device.publish(0.0, np.zeros(6), np.zeros(6))
    poll = DevicePoll(device)
    lp = LowPassFilter(8.0) if lowpass else None
    moved, fastest, back, t_prev = 0.0, 0.0, 0.0, loop_times[0]
    for t in loop_times:
        while pending and pending[0] <= t:
            td = pending.pop(0)
            tw, d = np.zeros(6), np.zeros(6)
            tw[0], d[0] = speed(td), move(td)
            device.publish(td, tw, d)
        p = poll(t - t_prev)
        t_prev = t
        v = lp.over(p["twist"], p["h"]) if lp is not None else p["twist"]
        moved += float(v[0]) * p["h"]
        fastest = max(fastest, abs(float(v[0])))
        back = max(back, -float(v[0]) * p["h"])
    return moved, fastest, back


LOOP = list(np.arange(0.0, 2.0, 1 / 30))  # a 30 Hz loop
STALL = [t for t in np.arange(0.01, 2.0, 0.01) if not 0.45 < t < 0.95]  # 100 Hz, then silent for 0.5 s mid-move
SLOWING = [t for t in np.arange(0.01, 2.0, 0.01) if not 0.85 < t < 1.35]  # ... while it slows down to rest


@pytest.mark.parametrize("running_total", [True, False])
def test_a_loop_faster_than_the_device_moves_the_target_as_far_as_the_device(running_total):
    """A 20 Hz device polled at 30 Hz: every other cycle holds its last twist; the next hands out only what
    remains, so the target lands where the device did."""
    device_times = list(np.arange(0.05, 2.0, 0.05))
    moved, fastest, back = run(Device(running_total), device_times, LOOP)
    assert moved == pytest.approx(move(2.0) if running_total else _trapezoid(device_times), abs=1e-12)
    assert fastest <= 0.2 + 1e-9  # never faster than the device (peak 0.2 m/s)
    assert back < 1e-4  # a hold that overshot the slowing device is taken back the next cycle: a hair


@pytest.mark.parametrize("stall", [STALL, SLOWING])
def test_a_device_stalled_mid_move_costs_nothing_when_it_publishes_its_running_total(stall):
    """The device's thread stalled 0.5 s mid-move, speeding up or slowing down: the loop holds its last
    twist for a sample interval and a half, then waits; the next sample's running total says where the
    device got to. The target ends exactly there, through the low-pass too, never faster than the device
    went and never backwards (holding on through the stall overshot a slowing device, then came back)."""
    moved, fastest, back = run(Device(True), stall, LOOP, lowpass=True)
    assert moved == pytest.approx(0.1, abs=1e-9)
    assert fastest <= 0.2 + 1e-9 and back == 0.0


def test_without_a_running_total_a_stall_is_bridged_by_a_straight_line_and_nothing_more():
    """The same stall from a device that publishes only its twist: the trapezoid rule draws a straight line
    across the gap (all that can be known), and the target ends exactly where that says, the hold
    meanwhile taken back."""
    moved, _, _ = run(Device(False), STALL, LOOP)
    assert moved == pytest.approx(_trapezoid(STALL), abs=1e-12)
    assert abs(moved - 0.1) > 1e-3  # what the running total is for: the line misses the curve


def test_the_low_pass_starts_from_rest():
    """A filter that first sees a device mid-motion (its samples since a stall) starts from zero, so the
    integral of what it passes equals the input's; started at its first input it adds tau * x0."""
    spans, x = [0.5, 1 / 30, 1 / 30, 0.3, 0.3, 0.3], [0.05, 0.02, 0.0, 0.0, 0.0, 0.0]  # then at rest
    lp = LowPassFilter(8.0)
    out = sum(float(lp.over(v, h)) * h for v, h in zip(x, spans, strict=True))
    assert out == pytest.approx(sum(v * h for v, h in zip(x, spans, strict=True)), abs=1e-6)
    assert float(LowPassFilter(8.0).over(0.05, 0.0)) == 0.0


def test_the_scripts_running_total_is_the_integral_of_its_twist_and_carries_over_a_restart():
    node = ScriptedTeleop(script="moves", moves=[[0.04, -0.02, 0.01, 1.0, 0.8], [0.0, 0.03, 0.0, 0.0, 0.5]])
    node.setup()
    node.t_start = 0.0
    ts = np.linspace(0.0, 1.3, 2601)
    vel = np.array([node.moves[0].delta if t < 0.8 else node.moves[1].delta for t in ts]) * \
        np.array([bump(t, 0.8) if t < 0.8 else bump(t - 0.8, 0.5) for t in ts])[:, None]
    integral = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (vel[1:] + vel[:-1]) * np.diff(ts)[:, None], 0)])
    for i in (0, 700, 1600, 2000, 2600):
        assert np.allclose(node._moved(ts[i]), integral[i], atol=1e-7), ts[i]
    assert np.allclose(node._moved(9.0), [0.04, 0.01, 0.01])
    node.carried = node._moved(0.4)  # a restart 0.4 s in: the total goes on from there, no jump back
    assert np.allclose(node._moved(0.0), node.carried)
    assert bump_integral(0.5, 1.0) == pytest.approx(0.5) and math.isclose(bump_integral(2.0, 1.0), 1.0)


def _trapezoid(device_times) -> float:
    ts = np.array([0.0, *sorted(device_times)])
    v = np.array([speed(t) for t in ts])
    return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(ts)))
