"""The emulated bus backed by rio-sim's MuJoCo SO-100 (`port = "sim"`): the real follower and gripper
drivers move the simulated arm, and leader-follower works against physics."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rio_sim")
pytest.importorskip("mujoco")

from rio_so100.calibration import default_calibration  # noqa: E402
from rio_so100.emulator.sim import parse_sim_port  # noqa: E402

from rio.station.load import parse_station  # noqa: E402
from rio.workflows.teleop import run_teleop as run  # noqa: E402

SIM_HOME = np.array([0.0, 0.0706, 1.6431, 1.4278, 1.5708])  # rio-sim's so100 home pose


def test_parse_sim_port():
    assert parse_sim_port("sim") == ("arm", "sim")
    assert parse_sim_port("sim:left@w2") == ("left", "w2")
    assert parse_sim_port("/dev/ttyACM0") is None and parse_sim_port("virtual") is None


def test_leader_drives_the_simulated_arm_through_the_real_driver(make_vbus, calibrated):
    calibrated("default", "leader")
    leader_bus = make_vbus()
    target = SIM_HOME + np.array([-0.3, -0.2, -0.25, -0.2, 0.3])  # turned away from the scene's cube
    cal = default_calibration("so100", "leader")
    names = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]
    steps = [cal.joint(n).to_steps(q) for n, q in zip(names, target, strict=True)]
    steps.append(cal.joint("gripper").from_fraction(0.5))
    with leader_bus.lock:
        for sid, s in enumerate(steps, 1):
            leader_bus.servo(sid).hand = lambda t, s=s: s
    st = parse_station({"name": "so100-sim-test", "rate_hz": 50, "middleware": {"name": "thread"},
                        "components": {"world_sensor": {"driver": "sim.world", "scene": "so100"},
                                       "arm": {"driver": "so100.follower", "port": "sim"},
                                       "gripper": {"driver": "so100.gripper", "port": "sim"},
                                       "teleop": {"driver": "so100.leader", "port": leader_bus.port}}},
                       source="<test>")
    last = {}

    def on_step(tick):
        last["obs"] = tick.step.observation

    summary = run(st, duration=4.0, align_speed=1.0, on_tick=on_step, log=None)  # slack for a loaded CI machine
    arm = summary.details["pairs"][0]
    assert arm["align_s"] is not None and arm["align_s"] < 1.0, summary.format()
    obs = last["obs"]
    # the follower's joints (read through the SDK from the simulated servos) reached the leader's pose
    assert np.allclose(obs.proprio_joints, target, atol=0.03), obs.proprio_joints
    assert obs.gripper_width == pytest.approx(0.03, abs=0.003)  # half-open jaw -> half the fingers' width
