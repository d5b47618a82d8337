"""The packaged stations end to end through the real loop (thread middleware): on `gen3-fake` the fake
base traces the scripted square; on `gen3-sim` it drives rio-sim's Gen3 (joints through physics, the
2F-85's goal to the simulated fingers) through the scripted pick-and-place, and the world's ground truth
says the cube was carried to the pad, in a run the sim station records (the code of `rio teleop
--record`) that `run_deploy` replays, putting the cube down where it was taught. The sim arm must be the
driver's arm for any of this to work: its kinematics are checked against Kinova's DH table."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rio_kinova import dh
from rio_kinova.models import get_arm

from rio.testing import run_scripted_square

SIM = "gen3-sim"


def needs_sim() -> None:
    pytest.importorskip("rio_sim")
    pytest.importorskip("mujoco")


def test_fake_station_traces_the_scripted_square():
    run_scripted_square("gen3-fake")


def test_the_sim_gen3_is_the_drivers_arm_with_the_stations_tool():
    """rio-sim's Gen3 (grasp site) = Kinova's DH flange + the station's tcp_offset, its limited joints have
    Kinova's limits, and the station homes the arm to rio-sim's home."""
    needs_sim()
    import mujoco
    from rio_sim.robots import get_robot

    from rio.station.load import load_station

    robot, arm = get_robot("gen3"), get_arm("gen3")
    cfg = load_station(SIM).components["arm"].config
    assert cfg.tcp_offset[:2] == (0.0, 0.0) and cfg.tcp_offset[3:] == (0.0, 0.0, 0.0)
    np.testing.assert_allclose(cfg.home, robot.home)
    model = mujoco.MjModel.from_xml_path(str(robot.path))
    data = mujoco.MjData(model)
    adr = [model.joint(n).qposadr[0] for n in robot.arm_joints]
    rng = np.random.default_rng(7)
    lo = np.array([max(lo, -math.pi) for lo, _ in arm.limits])
    hi = np.array([min(hi, math.pi) for _, hi in arm.limits])
    for q in [np.array(robot.home), *rng.uniform(lo, hi, (20, arm.dof))]:
        data.qpos[adr] = q
        mujoco.mj_kinematics(model, data)
        t = dh.fk(arm.dh, q, arm.dh_base)
        np.testing.assert_allclose(data.site("grasp").xpos, t[:3, 3] + cfg.tcp_offset[2] * t[:3, 2], atol=1e-6)
        np.testing.assert_allclose(data.site("grasp").xmat.reshape(3, 3), t[:3, :3], atol=1e-6)
    for name, (low, high) in zip(robot.arm_joints, arm.limits, strict=True):
        span = model.joint(name).range
        if math.isinf(low):  # continuous on the robot: a stop no session reaches
            assert span[0] <= -2 * math.pi and span[1] >= 2 * math.pi, (name, span)
        else:
            np.testing.assert_allclose(span, (low, high), atol=1e-6)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """One scripted pick-and-place recorded by the code of `rio teleop gen3-sim --teleop scripted --record`."""
    needs_sim()
    from rio_sim.testing import record_pick_and_place

    return record_pick_and_place(SIM, tmp_path_factory.mktemp("data") / "pick")


@pytest.mark.slow
def test_the_recording_holds_the_pick_arm_gripper_and_cameras(recorded):
    from rio_sim.scenes import CUBE
    from rio_sim.testing import check_recorded_pick_and_place

    ep = check_recorded_pick_and_place(recorded, "gen3")  # the world's ground truth: the cube on the pad
    # the gripper node reports the simulated fingers: stopped by the cube while carrying it, open at the end
    widths = ep.column("obs.gripper_width")
    assert abs(widths.min() - CUBE) < 0.006 and widths[-1] > 0.08, (widths.min(), widths[-1])


@pytest.mark.slow
def test_deploy_replaying_the_episode_does_the_task_again(recorded, tmp_path):
    from rio_sim.testing import check_replay_repeats_the_task

    check_replay_repeats_the_task(SIM, recorded, tmp_path / "rollout")
