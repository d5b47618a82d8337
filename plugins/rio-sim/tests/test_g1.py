"""The simulated Unitree G1 (`sim.g1`, `sim.g1_hand`, station `sim-g1`): the asset keeps Unitree's names,
order, limits and masses; on its stand it holds its pose under gravity; `rio teleop sim-g1` with the
scripted hand tracker moves both wrists by the tracker's motion and curls the Dex3-1 fingers while the
legs stay; a recorded humanoid episode replays to the same joint trajectory."""

from __future__ import annotations

import copy
import uuid
from contextlib import contextmanager

import numpy as np
import pytest
from rio_sim import g1
from rio_sim.indices import joint_indices
from rio_sim.robots import ASSETS
from rio_sim.scenes import TABLE_HEIGHT, build_model
from rio_sim.testing import check_humanoid_replay
from rio_sim.world import SimWorld

from rio import ServerManager, serve
from rio.conformance.drivers import HandConformance, HumanoidConformance
from rio.kinematics import HandRetargeter, MultiFrameIK
from rio.recording.dataset import Dataset
from rio.station import make_station
from rio.station.load import load_station
from rio.workflows.teleop import run_teleop

mujoco = pytest.importorskip("mujoco")

#: Spot checks against Unitree's URDF (example-robot-data 6.0.0): (lower, upper) rad, effort N m, velocity rad/s.
URDF = {"left_hip_pitch_joint": (-2.5307, 2.8798, 88, 32), "right_hip_roll_joint": (-2.9671, 0.5236, 139, 20),
        "left_knee_joint": (-0.087267, 2.8798, 139, 20), "right_ankle_pitch_joint": (-0.87267, 0.5236, 35, 30),
        "waist_yaw_joint": (-2.618, 2.618, 88, 32), "waist_pitch_joint": (-0.52, 0.52, 35, 30),
        "right_shoulder_roll_joint": (-2.2515, 1.5882, 25, 37), "left_elbow_joint": (-1.0472, 2.0944, 25, 37),
        "left_wrist_yaw_joint": (-1.614429558, 1.614429558, 5, 22),
        "right_hand_index_0_joint": (0.0, 1.57079632, 1.4, 12), "left_hand_thumb_0_joint": (-1.04719755, 1.04719755,
                                                                                             2.45, 3.14)}
FLEX = ("index_0", "index_1", "middle_0", "middle_1")  # the fingers' flexion joints (negative on the left hand)


def asset(hands: bool):
    return mujoco.MjModel.from_xml_path(str(ASSETS / (g1.HANDS_ASSET if hands else g1.ASSET)))


@pytest.mark.parametrize("hands", [False, True])
def test_the_asset_keeps_unitrees_names_order_limits_and_masses(hands):
    m = asset(hands)
    assert (ASSETS / (g1.HANDS_ASSET if hands else g1.ASSET)).stat().st_size < 60_000
    motors = list(g1.JOINTS) + (list(g1.HAND_JOINTS["left"] + g1.HAND_JOINTS["right"]) if hands else [])
    assert [m.actuator(i).name for i in range(m.nu)] == motors  # Unitree's motor order
    if not hands:  # the joints too (with hands, each hand's joints follow its wrist in the tree)
        assert [m.joint(i).name for i in range(1, m.njnt)] == list(g1.JOINTS)
    for name, (lo, hi, effort, velocity) in URDF.items():
        if "hand" in name and not hands:
            continue
        j = m.joint(name)
        assert np.allclose(j.range, [lo, hi]) and np.allclose(m.jnt_actfrcrange[j.id], [-effort, effort]), name
        assert m.jnt_user[j.id][0] == pytest.approx(velocity), name
    assert m.body("torso_link").mass[0] == pytest.approx(6.78) and m.body("pelvis").mass[0] == pytest.approx(3.813)
    total = float(m.body_subtreemass[m.body("pelvis").id])
    assert total == pytest.approx(34.39 if hands else 33.34, abs=0.01)  # Unitree: "about 35 kg"


def test_on_its_stand_it_holds_home_under_gravity_and_free_it_falls():
    """Home pose, soles just above the floor; 2 s of physics with the servos' targets at home: every
    joint within 1e-3 rad (the gravity feed-forward leaves the PD nothing to hold). Free, it sags."""
    for name, mounted in (("g1", True), ("g1:floating", False)):
        m = copy.deepcopy(build_model(name))
        d = mujoco.MjData(m)
        idx = joint_indices(m, "g1", g1.JOINTS)
        d.qpos[idx.qpos] = d.ctrl[idx.act] = g1.home()
        mujoco.mj_forward(m, d)
        soles = [d.geom(f"g1/{s}_ankle_roll_sole") for s in ("left", "right")]
        heights = [s.xpos[2] - m.geom(s.id).size[2] + TABLE_HEIGHT for s in soles]
        assert all(0.0 < h < 0.002 for h in heights), heights
        z0 = d.body("g1/pelvis").xpos[2]
        err = 0.0
        for _ in range(1000):
            mujoco.mj_step(m, d)
            err = max(err, float(np.abs(d.qpos[idx.qpos] - g1.home()).max()))
        if mounted:
            assert err < 1e-3 and d.body("g1/pelvis").xpos[2] == z0
        else:
            assert err > 0.05 and d.body("g1/pelvis").xpos[2] < z0 - 0.005


def test_the_descriptions_leave_the_legs_alone_and_put_the_palm_in_rios_frame():
    desc = {"format": "mjcf", "xml": g1.asset_text(), "joints": list(g1.JOINTS), "frames": g1.FRAMES,
            "frame_type": "site", "home": g1.home()}
    ik = MultiFrameIK(desc)
    assert not [n for n in ik.solved_joints if "hip" in n or "knee" in n or "ankle" in n]
    assert len(ik.solved_joints) == 17  # waist and both arms
    for side, sign in (("left", -1.0), ("right", 1.0)):
        hand = {"format": "mjcf", "xml": g1.hand_xml(side), "joints": list(g1.HAND_JOINTS[side]),
                "keypoints": g1.keypoints(side), "palm": f"{side}_palm", "side": side}
        r = HandRetargeter(hand)
        open_hand = r.model_keypoints(np.zeros(7))
        tip = open_hand["index-finger-tip"]
        assert tip[0] > 0.08 and abs(tip[2]) < 0.01  # fingers along x, in the palm's plane when open
        assert sign * open_hand["index-finger-phalanx-proximal"][1] < -0.02  # the index on the thumb's side
        q = np.zeros(7)
        q[[g1.HAND_JOINTS[side].index(f"{side}_hand_{j}_joint") for j in ("index_0", "index_1")]] = sign * 1.0
        assert r.model_keypoints(q)["index-finger-tip"][2] > 0.03  # flexed: toward the palm's side (+z)


FREE = """
name = "g1-free"
rate_hz = 30
[middleware]
name = "thread"
[components.world_sensor]
driver = "sim.world"
scene = "g1"
world = "g1free"
mounted = false
[components.humanoid]
driver = "sim.g1"
world = "g1free"
gains = { arms = [100.0, 4.0], left_knee_joint = [150.0, 4.0] }
"""


def test_free_floating_it_tips_over_its_imu_says_so_and_its_group_and_joint_gains_reach_the_world(tmp_path):
    """No locomotion policy: the G1 leans forward onto the table (~0.13 rad in 2 s); an episode's start stands
    it up again (no task: nothing else moves)."""
    from rio_sim.bus import WorldBus

    from rio.control.rotations import quat_angle
    from rio.testing import wait_until

    path = tmp_path / "free.toml"
    path.write_text(FREE)
    servers, clients, _ = make_station(str(path))
    with ServerManager(servers), clients["humanoid"]() as body, clients["world_sensor"]() as world:
        def tilt() -> float:
            return quat_angle(body.get_state()["base_quat"], [1, 0, 0, 0])

        assert wait_until(lambda: tilt() > 0.05, 10.0), body.get_state()["base_quat"]
        assert world.start_episode(0, 0) is None
        assert wait_until(lambda: tilt() < 0.02, 5.0), tilt()  # on its feet again, tipping from there
        assert wait_until(lambda: tilt() > 0.05, 10.0), tilt()
        bus = WorldBus.attach("g1free", timeout=5)
        try:
            idx = joint_indices(build_model("g1:floating"), "g1", g1.JOINTS)
            kp, kd = bus.gain_kp[idx.act], bus.gain_kd[idx.act]
            arms = [g1.group(n) == "arms" for n in g1.JOINTS]
            assert np.all(kp[arms] == 100.0) and np.all(kd[arms] == 4.0)
            assert kp[0] == g1.GAINS["legs"][0] and kd[0] == g1.GAINS["legs"][1]
            knee = g1.JOINTS.index("left_knee_joint")  # a joint's own gains override its group's
            assert (kp[knee], kd[knee]) == (150.0, 4.0) and kp[g1.JOINTS.index("right_knee_joint")] == 300.0
        finally:
            bus.close()


@pytest.fixture(scope="module")
def teleop_run(tmp_path_factory):
    """`rio teleop sim-g1` (its code, thread middleware) with the station's scripted hand tracker,
    recorded."""
    root = tmp_path_factory.mktemp("g1") / "data"
    ticks: list = []
    summary = run_teleop("sim-g1", duration=3.0, middleware="thread", record=str(root), on_tick=ticks.append,
                         log=None)
    return summary, ticks, root


def test_teleop_moves_both_wrists_by_the_trackers_motion_and_curls_the_fingers(teleop_run):
    summary, ticks, _ = teleop_run
    move = np.asarray(load_station("sim-g1").components["teleop"].config.move)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    assert np.allclose(first.joint_pos, g1.home(), atol=1e-3), summary.format()
    ik = MultiFrameIK({"format": "mjcf", "xml": g1.asset_text(), "joints": list(g1.JOINTS), "frames": g1.FRAMES})
    for frame in ("left", "right"):  # measured joints, forward kinematics: where the wrists really went
        moved = ik.fk(last.joint_pos, frame)[:3] - ik.fk(first.joint_pos, frame)[:3]
        assert np.allclose(moved, move, atol=0.006), (frame, moved, summary.format())
    legs = [i for i, n in enumerate(g1.JOINTS) if "hip" in n or "knee" in n or "ankle" in n]
    assert np.abs(last.joint_pos[legs] - first.joint_pos[legs]).max() < 1e-3
    assert np.allclose(last.base_quat, [1, 0, 0, 0]) and np.allclose(last.base_ang_vel, 0)  # on its stand
    for hand, side, sign in ((last.hand1_joints, "left", -1.0), (last.hand2_joints, "right", 1.0)):
        flex = [g1.HAND_JOINTS[side].index(f"{side}_hand_{j}_joint") for j in FLEX]
        assert (sign * hand[flex]).min() > 0.5, (side, hand)  # curled toward the palm
    assert np.abs(first.hand1_joints).max() < 0.05 and np.abs(first.hand2_joints).max() < 0.05


def test_a_recorded_humanoid_episode_replays_to_the_same_joint_trajectory(teleop_run):
    _, _, root = teleop_run
    ep = Dataset(root).episode(0)
    assert ep.meta["embodiment"] == "humanoid" and "head" in ep.cameras
    assert ep.column("obs.proprio").shape[1] == 29 + 14  # body, then left and right hand joints
    check_humanoid_replay(root, "sim-g1", body_dof=29)


class InG1World:
    """Emulator hook of the driver conformance kit: a fresh `sim.world` of the G1 scene."""

    @contextmanager
    def emulator(self):
        world = f"kit-{uuid.uuid4().hex[:8]}"
        with ServerManager("thread", [serve(SimWorld, name=f"{world}-world", world=world, scene="g1")],
                           station=world):
            yield {"world": world}


class TestSimG1(InG1World, HumanoidConformance):
    driver = "sim.g1"
    bad_config = {"humanoid": "no_such_humanoid"}


class TestSimG1Hand(InG1World, HandConformance):
    driver = "sim.g1_hand"
    config = {"side": "left"}
    bad_config = {"humanoid": "no_such_humanoid"}
