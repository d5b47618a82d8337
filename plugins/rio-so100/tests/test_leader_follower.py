"""Leader-follower teleop over two emulated buses: the follower first moves slowly to the leader's
pose, then mirrors it; ALOHA-style with two pairs."""

from __future__ import annotations

import numpy as np
import pytest
from rio_so100.calibration import RAD_PER_STEP, default_calibration

from rio.errors import RioError
from rio.station.load import parse_station
from rio.workflows.teleop import run_teleop as run

LEADER_Q = np.array([0.3, -0.25, 0.4, 0.15, -0.35])
LATER_Q = np.array([0.1, 0.2, 0.1, -0.2, 0.3])


def _station(follower_port: str, leader_port: str):
    return parse_station({
        "name": "lf-test", "rate_hz": 50, "middleware": {"name": "thread"},
        "components": {
            "arm": {"driver": "so100.follower", "port": follower_port},
            "gripper": {"driver": "so100.gripper", "port": follower_port},
            "teleop": {"driver": "so100.leader", "port": leader_port},
        }}, source="<test>")


def _pose_leader(bus, q, grip_fraction):
    """A person holding the (torque-off) leader in pose `q` (rad) with the jaw `grip_fraction` open."""
    cal = default_calibration("so100", "leader")
    with bus.lock:
        for sid, name in enumerate(["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"], 1):
            steps = cal.joint(name).to_steps(float(q[sid - 1]))
            bus.servo(sid).hand = lambda t, s=steps: s
        steps = cal.joint("gripper").from_fraction(grip_fraction)
        bus.servo(6).hand = lambda t, s=steps: s


def test_follower_aligns_slowly_then_mirrors_the_leader(make_vbus, calibrated):
    calibrated("default", "follower")
    calibrated("default", "leader")
    follower_bus, leader_bus = make_vbus(), make_vbus()
    _pose_leader(leader_bus, LEADER_Q, 0.5)
    cmds, moved = [], []

    def on_step(tick):
        p = tick.info["pairs"][0]
        cmds.append((tick.t, p.q_cmd.copy(), p.aligned))
        if tick.t - cmds[0][0] > 1.4 and not moved:  # the person moves the leader once aligned
            _pose_leader(leader_bus, LATER_Q, 0.2)
            moved.append(tick.t)

    summary = run(_station(follower_bus.port, leader_bus.port), duration=2.2, align_speed=0.5, on_tick=on_step,
                  log=None)
    arm = summary.details["pairs"][0]
    assert arm["start_error"] == pytest.approx(0.4, abs=2 * RAD_PER_STEP)
    # alignment took about start_error / align_speed, never faster than align_speed
    assert 0.7 < arm["align_s"] < 1.1, summary.format()
    aligning = [(t, q) for t, q, aligned in cmds if not aligned]
    speeds = [np.max(np.abs(q1 - q0)) / (t1 - t0)
              for (t0, q0), (t1, q1) in zip(aligning[:-1], aligning[1:], strict=True)]
    assert max(speeds) <= 0.5 * 1.3, max(speeds)  # per-tick steps of align_speed * dt (tick jitter aside)
    # then it mirrored the leader, including the later move, and the gripper followed the jaw
    assert moved and arm["final_error"] < 3 * RAD_PER_STEP, summary.format()
    assert np.allclose(cmds[-1][1], LATER_Q, atol=2 * RAD_PER_STEP)
    jaw = default_calibration("so100", "follower").joint("gripper")
    assert follower_bus.servo(6).reg((42, 2)) == pytest.approx(jaw.from_fraction(0.2), abs=2)
    assert summary.late_ticks < summary.ticks // 5


def test_bimanual_emulator_station_aligns_both_pairs():
    summary = run("so100-bimanual-emulator", duration=2.0, middleware="thread", log=None)
    assert [a["arm"] for a in summary.details["pairs"]] == ["arm", "arm2"]
    for a in summary.details["pairs"]:
        assert a["align_s"] is not None and a["align_s"] < 1.5, summary.format()
        assert a["final_error"] < 0.08, summary.format()  # the leaders keep waving: a cycle or two of lag


def test_a_station_without_leader_arms_is_refused():
    st = parse_station({"name": "x", "middleware": {"name": "thread"},
                        "components": {"arm": {"driver": "so100.follower", "port": "emulator"}}}, source="<test>")
    with pytest.raises(RioError, match="has no teleop component"):
        run(st, duration=0.1, log=None)


@pytest.mark.slow
def test_rio_teleop_command_mirrors_with_a_leader_device(tmp_path):
    """`rio teleop STATION --teleop so100.leader --record DIR` (the core command) runs leader-follower,
    ALOHA-style with two pairs, over emulated buses, and records the run as an episode."""
    import os

    from rio.recording.dataset import Dataset
    from rio.testing import run_rio

    env = {**os.environ, "XDG_CONFIG_HOME": str(tmp_path)}
    data = tmp_path / "aloha"
    out = run_rio("teleop", "so100-bimanual-emulator", "--teleop", "so100.leader", "--duration", "2.5",
                  "--record", str(data), "--on-end", "keep", timeout=180, env=env)
    assert "arm <- teleop:" in out.stdout and "arm2 <- teleop2:" in out.stdout
    assert out.stdout.count("aligned after") == 2, out.stdout
    ep = Dataset(data).episode(0)
    assert ep.meta["embodiment"] == "bimanual"
    assert len(ep) >= 0.8 * 2.5 * ep.fps and ep.column("action").shape[1] == ep.column("obs.proprio").shape[1]
