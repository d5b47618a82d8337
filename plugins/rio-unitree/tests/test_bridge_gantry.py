"""The bridge's gantry (`rio_unitree.bridge.gantry`): a free G1 hangs still from the start, is lowered
when released (by call, or `release_after_s` after its legs are first commanded stiff), without a drop, and
then nothing holds it. Physics stepped directly (no DDS, no wall clock), on the plugin's own G1-like model."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")
from rio_unitree.bridge import Bridge  # noqa: E402
from rio_unitree.bridge.gantry import HOLDING, LOWERING, RELEASED  # noqa: E402


def steps(bridge: Bridge, seconds: float) -> list[tuple[float, float, float, str]]:
    """Step `seconds` of physics; (time, pelvis height, tilt deg, gantry state) after each step."""
    out = []
    d, pelvis = bridge.sim.data, bridge.sim.pelvis
    for _ in range(round(seconds / bridge.dt)):
        bridge._step()
        w, x, y, z = d.xquat[pelvis]
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (x * x + y * y)))))
        out.append((float(d.time), float(d.xpos[pelvis][2]), tilt, bridge.gantry.state if bridge.gantry else ""))
    return out


def stiff_legs(bridge: Bridge):
    """An rt/lowcmd holding the start pose with every motor stiff (what a driver holding the robot sends)."""
    n = len(bridge.sim.slots)
    return bridge._command(bridge.start_q, np.full(n, 300.0), np.full(n, 3.0))


def test_it_holds_the_free_g1_still_where_nothing_else_would():
    held = Bridge(model="fallback", mounted=False, gantry=True)
    z0 = float(held.sim.data.xpos[held.sim.pelvis][2])
    trace = np.array([r[:3] for r in steps(held, 3.0)])
    # within a centimetre of where it started (its soles touch the floor there) and still after a second
    assert np.abs(trace[:, 1] - z0).max() < 0.015 and trace[:, 2].max() < 1.0
    assert np.ptp(trace[-1000:, 1]) < 0.002
    assert held.gantry.state == HOLDING  # no release asked for, no controller: it keeps hanging
    free = Bridge(model="fallback", mounted=False)  # the same robot, no gantry: it drops and topples
    trace = np.array([r[:3] for r in steps(free, 3.0)])
    assert trace[:, 1].min() < z0 - 0.05 or trace[:, 2].max() > 10.0


def test_release_lowers_it_onto_its_feet_without_a_drop():
    bridge = Bridge(model="fallback", mounted=False, gantry=True, lower_s=1.0)
    bridge.lowcmd = stiff_legs(bridge)
    steps(bridge, 0.5)
    bridge.release_gantry()
    rows = steps(bridge, 1.2)
    t, h = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
    states = [r[3] for r in rows]
    assert states[0] == LOWERING and states[-1] == RELEASED
    assert t[states.index(RELEASED)] == pytest.approx(1.5, abs=0.01)  # lower_s after the release
    speed = -np.diff(h) / bridge.dt
    assert speed.max() < 0.3  # lowered, not dropped (a free fall from 5 cm reaches 1 m/s)
    assert np.all(bridge.sim.data.xfrc_applied[bridge.sim.pelvis] == 0.0)  # nothing holds it any more
    bridge.reset()
    assert bridge.gantry.state == HOLDING  # a reset hangs it again


def test_release_after_counts_from_the_first_stiff_lowcmd():
    bridge = Bridge(model="fallback", mounted=False, gantry=True, release_after_s=0.5, lower_s=0.5)
    assert {r[3] for r in steps(bridge, 1.0)} == {HOLDING}  # the stand-in holds it: that is no controller
    soft = stiff_legs(bridge)
    soft.kp[:] = 0.0  # a driver's damping: kp 0, not holding the legs
    bridge.lowcmd = soft
    assert {r[3] for r in steps(bridge, 1.0)} == {HOLDING}
    bridge.lowcmd = stiff_legs(bridge)
    rows = steps(bridge, 1.2)
    first = next(r[0] for r in rows if r[3] == LOWERING)
    assert first == pytest.approx(2.5, abs=0.01)  # 0.5 s after the first stiff command (at 2.0 s)
    assert rows[-1][3] == RELEASED


@pytest.mark.parametrize("options, problem", [
    ({"gantry": True}, "free-floating"),  # mounted (the default): welded already
    ({"mounted": False, "release_after_s": 1.0}, "set gantry = true"),
    ({"mounted": False, "gantry": True, "lower_s": 0.0}, "lower_s"),
    ({"start_pose": {"left_knee": 0.3}}, "unknown G1 joints"),
])
def test_option_mistakes_are_named(options, problem):
    with pytest.raises(ValueError, match=problem):
        Bridge(model="fallback", **options)


def test_the_cli_refuses_release_after_without_a_gantry():
    from rio_unitree.cli import app
    from typer.testing import CliRunner

    result = CliRunner().invoke(app, ["bridge", "--release-after", "2"])
    assert result.exit_code == 1 and "--gantry" in result.output
