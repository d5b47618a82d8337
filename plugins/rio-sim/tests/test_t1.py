"""The simulated Booster T1 (`sim.t1`, station `sim-t1`): the asset keeps Booster's names, order, limits and
masses (Menagerie's booster_t1); on its stand it holds its pose under gravity; `rio teleop sim-t1` with the
scripted hand tracker moves both hands by the tracker's motion while the legs, waist and head stay; a
recorded episode replays to the same joint trajectory; gains can be set per group and per joint."""

from __future__ import annotations

import copy
import uuid
from contextlib import contextmanager

import numpy as np
import pytest
from pydantic import ValidationError
from rio_sim import t1
from rio_sim.humanoid import SimHumanoid
from rio_sim.indices import joint_indices
from rio_sim.robots import ASSETS
from rio_sim.scenes import TABLE_HEIGHT, build_model
from rio_sim.testing import check_humanoid_replay, running_world

from rio import ServerManager
from rio.conformance.drivers import HumanoidConformance
from rio.kinematics import MultiFrameIK
from rio.recording.dataset import Dataset
from rio.station import make_station
from rio.station.load import load_station
from rio.workflows.teleop import run_teleop

mujoco = pytest.importorskip("mujoco")

#: Spot checks against Menagerie's booster_t1/t1.xml (commit 4f04d622): (lower, upper) rad, effort N m.
MENAGERIE = {"AAHead_yaw": (-1.57, 1.57, 7), "Head_pitch": (-0.35, 1.22, 7),
             "Left_Shoulder_Roll": (-1.74, 1.57, 18), "Right_Elbow_Yaw": (0.0, 2.44, 18), "Waist": (-1.57, 1.57, 30),
             "Left_Hip_Pitch": (-1.8, 1.57, 45), "Right_Hip_Roll": (-1.57, 0.2, 30),
             "Left_Knee_Pitch": (0.0, 2.34, 60), "Right_Ankle_Pitch": (-0.87, 0.35, 20),
             "Left_Ankle_Roll": (-0.44, 0.44, 15)}
STILL = ("Hip", "Knee", "Ankle", "Head", "Waist")  # not on the hands' chains


def test_the_asset_keeps_boosters_names_order_limits_and_masses():
    m = mujoco.MjModel.from_xml_path(str(ASSETS / t1.ASSET))
    assert (ASSETS / t1.ASSET).stat().st_size < 30_000 and m.nmesh == 0  # primitives only
    assert [m.actuator(i).name for i in range(m.nu)] == list(t1.JOINTS)  # Booster's JointIndex order
    assert [m.joint(i).name for i in range(1, m.njnt)] == list(t1.JOINTS)
    for name, (lo, hi, effort) in MENAGERIE.items():
        j = m.joint(name)
        assert np.allclose(j.range, [lo, hi]) and np.allclose(m.jnt_actfrcrange[j.id], [-effort, effort]), name
    assert m.body("Trunk").mass[0] == pytest.approx(11.7) and m.body("Shank_Right").mass[0] == pytest.approx(1.79)
    assert float(m.body_subtreemass[m.body("Trunk").id]) == pytest.approx(31.61, abs=0.01)


def test_the_joint_table_agrees_with_rio_booster():
    booster = pytest.importorskip("rio_booster.t1")
    m = mujoco.MjModel.from_xml_path(str(ASSETS / t1.ASSET))
    assert list(t1.JOINTS) == booster.joint_names()
    for j in booster.JOINTS:
        assert np.allclose(m.joint(j.name).range, [j.lower, j.upper]), j.name
        assert m.jnt_actfrcrange[m.joint(j.name).id][1] == pytest.approx(j.effort), j.name
        assert t1.GAINS[t1.group(j.name)] == (j.kp, j.kd), j.name  # the real T1's default gains
    home = dict(zip(t1.JOINTS, t1.home(), strict=True))
    assert all(home[n] == v for n, v in booster.HOME.items() if "Hip" in n or "Knee" in n or "Ankle" in n)


def test_on_its_stand_it_holds_home_under_gravity_and_free_it_falls():
    """Home pose, soles just above the floor, hands over the table; 2 s of physics with the servos' targets
    at home: every joint within 1e-3 rad. Free, it sags."""
    for name, mounted in (("t1", True), ("t1:floating", False)):
        m = copy.deepcopy(build_model(name))
        d = mujoco.MjData(m)
        idx = joint_indices(m, "t1", t1.JOINTS)
        d.qpos[idx.qpos] = d.ctrl[idx.act] = t1.home()
        mujoco.mj_forward(m, d)
        soles = [d.geom(f"t1/{s}_sole") for s in ("left", "right")]
        heights = [s.xpos[2] - m.geom(s.id).size[2] + TABLE_HEIGHT for s in soles]
        assert all(0.0 < h < 0.002 for h in heights), heights
        for side, sign in (("left", 1), ("right", -1)):
            hand = d.site(f"t1/{t1.FRAMES[side]}").xpos
            assert 0.3 < hand[0] < 0.4 and 0.1 < sign * hand[1] < 0.2 and 0.05 < hand[2] < 0.15, (side, hand)
        z0 = d.body("t1/Trunk").xpos[2]
        err = 0.0
        for _ in range(1000):
            mujoco.mj_step(m, d)
            err = max(err, float(np.abs(d.qpos[idx.qpos] - t1.home()).max()))
        if mounted:
            assert err < 1e-3 and d.body("t1/Trunk").xpos[2] == z0
        else:
            assert err > 0.02 and d.body("t1/Trunk").xpos[2] < z0 - 0.002


def test_the_hands_ik_moves_only_the_arms():
    ik = MultiFrameIK({"format": "mjcf", "xml": t1.asset_text(), "joints": list(t1.JOINTS), "frames": t1.FRAMES})
    assert ik.solved_joints == [n for n in t1.JOINTS if "Shoulder" in n or "Elbow" in n]
    with pytest.raises(ValueError, match="no dexterous hands"):
        t1.asset_text(hands=True)


@pytest.mark.parametrize("robot, joint, group", [("g1", "left_knee_joint", "legs"),
                                                 ("t1", "Left_Knee_Pitch", "knees")])
def test_gains_take_groups_and_joint_names_and_name_an_unknown_key(robot, joint, group):
    ok = SimHumanoid.Config(robot=robot, gains={group: [120.0, 3.0], joint: [150.0, 4.0]})
    assert ok.gains[joint] == (150.0, 4.0)
    with pytest.raises(ValidationError, match="left_knee"):
        SimHumanoid.Config(robot=robot, gains={"left_knee": [150.0, 4.0]})
    with pytest.raises(ValidationError, match=f"must be >= 0 \\({joint}\\)"):
        SimHumanoid.Config(robot=robot, gains={joint: [-1.0, 4.0]})


GAINS = """
name = "t1-gains"
rate_hz = 30
[middleware]
name = "thread"
[components.world_sensor]
driver = "sim.world"
scene = "t1"
world = "t1gains"
[components.humanoid]
driver = "sim.t1"
world = "t1gains"
gains = { knees = [120.0, 3.0], Left_Knee_Pitch = [180.0, 5.0] }
"""


def test_group_and_joint_gains_reach_the_world(tmp_path):
    from rio_sim.bus import WorldBus

    from rio.testing import wait_until

    path = tmp_path / "gains.toml"
    path.write_text(GAINS)
    servers, clients, _ = make_station(str(path))
    with ServerManager(servers), clients["humanoid"]():
        bus = WorldBus.attach("t1gains", timeout=5)
        try:
            idx = joint_indices(build_model("t1"), "t1", t1.JOINTS)
            assert wait_until(lambda: bus.gain_kp[idx.act].max() > 0, 5.0)
            gains = {n: (bus.gain_kp[a], bus.gain_kd[a]) for n, a in zip(t1.JOINTS, idx.act, strict=True)}
            assert gains["Left_Knee_Pitch"] == (180.0, 5.0) and gains["Right_Knee_Pitch"] == (120.0, 3.0)
            assert gains["Left_Hip_Pitch"] == t1.GAINS["hips"] and gains["AAHead_yaw"] == t1.GAINS["head"]
        finally:
            bus.close()


@pytest.fixture(scope="module")
def teleop_run(tmp_path_factory):
    """`rio teleop sim-t1` (its code, thread middleware) with the station's scripted hand tracker, recorded."""
    root = tmp_path_factory.mktemp("t1") / "data"
    ticks: list = []
    summary = run_teleop("sim-t1", duration=3.0, middleware="thread", record=str(root), on_tick=ticks.append,
                         log=None)
    return summary, ticks, root


def test_teleop_moves_both_hands_by_the_trackers_motion_and_nothing_else(teleop_run):
    """Within 6 mm of the tracker's 6.7 cm: the hands' orientation gives way to their position (a 4-joint
    arm cannot keep both; the description's `orientation_cost`)."""
    summary, ticks, _ = teleop_run
    move = np.asarray(load_station("sim-t1").components["teleop"].config.move)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    assert np.allclose(first.joint_pos, t1.home(), atol=1e-3), summary.format()
    ik = MultiFrameIK({"format": "mjcf", "xml": t1.asset_text(), "joints": list(t1.JOINTS), "frames": t1.FRAMES})
    for frame in ("left", "right"):  # measured joints, forward kinematics: where the hands really went
        moved = ik.fk(last.joint_pos, frame)[:3] - ik.fk(first.joint_pos, frame)[:3]
        assert np.allclose(moved, move, atol=0.006), (frame, moved, summary.format())
    still = [i for i, n in enumerate(t1.JOINTS) if any(k in n for k in STILL)]
    assert np.abs(last.joint_pos[still] - first.joint_pos[still]).max() < 1e-3
    assert np.allclose(last.base_quat, [1, 0, 0, 0]) and np.allclose(last.base_ang_vel, 0)  # on its stand


def test_a_recorded_t1_episode_replays_to_the_same_joint_trajectory(teleop_run):
    _, _, root = teleop_run
    ep = Dataset(root).episode(0)
    assert ep.meta["embodiment"] == "humanoid" and "head" in ep.cameras
    assert ep.column("obs.proprio").shape[1] == len(t1.JOINTS)  # no hands
    check_humanoid_replay(root, "sim-t1", body_dof=len(t1.JOINTS))


class TestSimT1(HumanoidConformance):
    driver = "sim.t1"
    bad_config = {"humanoid": "no_such_humanoid"}

    @contextmanager
    def emulator(self):
        """The conformance kit's hook: a fresh `sim.world` of the T1 scene."""
        world = f"kit-{uuid.uuid4().hex[:8]}"
        with running_world("t1", world):
            yield {"world": world}
