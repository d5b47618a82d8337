"""The emulated T1 on rio-sim physics (`backend = "sim"`, station `t1-sim`): the unmodified driver against the
SDK-object fake (see test_driver.py for why a fake), its joints rio-sim's T1 in MuJoCo on a stand, gravity
real. On its stand the T1 holds the driver's home against gravity with the driver's gains; a disable's
damping (kp = 0) lets raised arms fall, which the gravity-free ideal backend cannot show; the IMU is the
trunk's; `rio teleop t1-sim` moves both hands by the scripted tracker's motion through the driver's IK
model (rio-sim's T1), and the recorded episode replays to the same joint trajectory."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from rio_booster.emulator import CUSTOM, EmulatedT1
from rio_booster.t1 import home_pose, joint_names

from rio import clock
from rio.conformance.driving import Loop, build_node, resolve_driver
from rio.interfaces.damping import FALL
from rio.testing import block_import, lifecycle, skip_tests_without

HAVE_SIM = importlib.util.find_spec("mujoco") is not None and importlib.util.find_spec("rio_sim") is not None
WHY = "the sim backend needs MuJoCo and rio-sim (pip install 'rio-booster[sim]')"
needs_sim = pytest.mark.skipif(not HAVE_SIM, reason=WHY)
NAMES = joint_names()
SHOULDERS = [NAMES.index(f"{side}_Shoulder_Pitch") for side in ("Left", "Right")]
ROLLS = [NAMES.index(f"{side}_Shoulder_Roll") for side in ("Left", "Right")]
STILL = ("Hip", "Knee", "Ankle", "Head", "Waist")  # not on the hands' chains
#: Sag of a held pose: the driver's PD gains (kp 10 on the head, 40 on the arms, 150 on the knees) and no
#: gravity feed-forward (the real T1 in custom mode gets none either): a few mrad.
HOLD_TOL_RAD = 0.02


def t1(domain_id: int, **fields):
    values = {"sdk": "rio_booster.emulator", "domain_id": domain_id, "rate_hz": 200.0, "prepare_s": 0.2,
              "max_step_rad": 0.02, "state_timeout_s": 1.0, "watchdog_s": 5.0, **fields}  # one command, then waits
    return build_node(resolve_driver("booster.t1"), values, "t1")


def hold(node, loop, q, seconds):
    """Stream `q` for `seconds` (a policy saying "stay"); the worst joint error seen after the first 0.3 s."""
    t0 = clock.now()
    worst = 0.0
    while clock.now() < t0 + seconds:
        node.handle_request({"joint_pos": np.asarray(q, np.float64), "t_cmd_target": clock.now() + 0.02})
        s = loop.tick()
        if clock.now() > t0 + 0.3:
            worst = max(worst, float(np.abs(s["joint_pos"] - q).max()))
    return s, worst


def test_an_unknown_backend_or_a_missing_rio_sim_is_named(monkeypatch):
    with pytest.raises(ValueError, match="unknown emulated T1 backend 'mujoco'"):
        EmulatedT1(backend="mujoco")
    block_import(monkeypatch, "rio_sim")
    with pytest.raises(ImportError, match="pip install rio-sim"):
        EmulatedT1(backend="sim")


@needs_sim
def test_on_its_stand_it_holds_home_against_gravity_through_the_driver(make_robot, domain_id):
    robot = make_robot(backend=f"sim@t1-hold-{domain_id}")
    node = t1(domain_id)
    with lifecycle(node):
        loop = Loop(node)
        home = np.asarray(home_pose())
        assert np.abs(loop.run(cycles=3)["joint_pos"] - home).max() < HOLD_TOL_RAD
        s, worst = hold(node, loop, home, 1.5)
        assert worst < HOLD_TOL_RAD, worst
        assert s["fault_code"] == 0 and s["robot_mode"] == CUSTOM and robot.counts.obeyed > 100
        assert np.allclose(s["base_quat"], [1, 0, 0, 0], atol=1e-9)  # the IMU is the mounted trunk's
        assert float(np.abs(robot.tau).max()) > 0.1  # the motors carry the limbs' weight
        robot.tilt(70.0)  # the mount turned: the trunk's orientation is what the driver reads as a fall
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == FALL and not s["enabled"]


def reach(node, loop, target, joints, tol=0.1, timeout=5.0):
    """Command `target` (arriving in 0.5 s) and run until `joints` are within `tol` of it (or `timeout`: a goal
    the physics does not let them reach), then 0.2 s."""
    node.handle_request({"joint_pos": target, "t_cmd_target": clock.now() + 0.5})
    loop.run(until=lambda s: np.abs(s["joint_pos"][joints] - target[joints]).max() < tol, timeout=timeout)
    return loop.run(cycles=40)


@needs_sim
@pytest.mark.parametrize("backend, real", [("sim", True), ("ideal", False)])
def test_damping_on_disable_lets_raised_arms_fall_under_gravity(make_robot, domain_id, backend, real):
    """Both arms raised sideways near horizontal (shoulder roll 1.1 rad up from the stand's), then a disable:
    damping (kp = 0, kd 1 on the arms). On the physics the arms swing down within 1.5 s, slowed by the
    damping; the ideal backend has no gravity, so they stay."""
    robot = make_robot(backend=backend if backend == "ideal" else f"sim@t1-damp-{domain_id}")
    node = t1(domain_id)
    with lifecycle(node):
        loop = Loop(node)
        raised = np.asarray(home_pose())
        raised[ROLLS] = [-0.3, 0.3]
        reach(node, loop, raised, ROLLS)
        up = robot.joint_pos()[ROLLS]
        assert np.abs(up - raised[ROLLS]).max() < 0.1, up  # kp 40 holds a horizontal arm ~0.06 rad low
        node.disable()
        assert robot.last_frame.is_damping()
        peak = 0.0
        for _ in range(30):  # 1.5 s; the fall's speed is what damping (kd 1) allows
            loop.run(cycles=10)
            peak = max(peak, float(np.abs(robot.dq[ROLLS]).max()))
        fell = np.abs(robot.joint_pos()[ROLLS] - up)
    if real:
        assert (fell > 0.5).all(), fell
        assert peak < 15.0, peak  # damped: far from a free fall's whip
    else:
        assert fell.max() < 0.01, fell


@needs_sim
@pytest.mark.parametrize("backend, real", [("sim", True), ("ideal", False)])
def test_the_table_stops_arms_swung_forward_into_it(make_robot, domain_id, backend, real):
    """From the stand (arms down at the sides, hands below the table top), both shoulders pitched 1.2 rad
    forward: on the physics the hands meet the table's front edge and the arms stop there, far short of the
    goal (contacts are real); the ideal backend's arms get there."""
    robot = make_robot(backend=backend if backend == "ideal" else f"sim@t1-table-{domain_id}")
    node = t1(domain_id)
    with lifecycle(node):
        loop = Loop(node)
        forward = np.asarray(home_pose())
        forward[SHOULDERS] = -1.2
        reach(node, loop, forward, SHOULDERS, timeout=2.5)
        short = np.abs(robot.joint_pos()[SHOULDERS] - forward[SHOULDERS])
    if real:
        assert (short > 0.3).all(), short
    else:
        assert short.max() < 0.05, short


@pytest.fixture(scope="module")
def teleop_run(tmp_path_factory):
    """`rio teleop t1-sim` (its code, thread middleware) with the station's scripted hand tracker, recorded."""
    if not HAVE_SIM:
        pytest.skip(WHY)
    from rio.workflows.teleop import run_teleop

    root = tmp_path_factory.mktemp("t1sim") / "data"
    ticks: list = []
    head: dict = {}

    def on_tick(tick):
        ticks.append(tick)
        head["rgb"] = np.array(tick.step.observation.cameras["head"].rgb)  # a copy: the frame's buffer is reused

    summary = run_teleop("t1-sim", duration=3.0, middleware="thread", record=str(root), on_tick=on_tick, log=None)
    return summary, ticks, root, head["rgb"]


@needs_sim
def test_teleop_moves_both_hands_by_the_trackers_motion_through_the_driver(teleop_run):
    """Within 1 cm of the tracker's 6.7 cm: the T1's 4-joint arms put position before orientation (as on
    sim-t1), and the driver's kp-40 arms hold the IK's goal a few mm low under gravity (no feed-forward)."""
    from rio.kinematics import MultiFrameIK
    from rio.station.load import load_station

    summary, ticks, _, _ = teleop_run
    move = np.asarray(load_station("t1-sim").components["teleop"].config.move)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    assert np.abs(first.joint_pos - home_pose()).max() < HOLD_TOL_RAD, summary.format()
    node = build_node(resolve_driver("booster.t1"), {"sdk": "rio_booster.emulator"}, "t1")
    description = node.robot_description()  # the driver's own model: rio-sim's T1
    assert description is not None and description["joints"] == NAMES
    ik = MultiFrameIK(description)
    for frame in ("left", "right"):  # measured joints, forward kinematics: where the hands really went
        moved = ik.fk(last.joint_pos, frame)[:3] - ik.fk(first.joint_pos, frame)[:3]
        assert np.allclose(moved, move, atol=0.01), (frame, moved, summary.format())
    still = [i for i, n in enumerate(NAMES) if any(k in n for k in STILL)]
    assert np.abs(last.joint_pos[still] - first.joint_pos[still]).max() < HOLD_TOL_RAD


@needs_sim
def test_the_head_camera_renders_the_emulated_robots_world(teleop_run):
    from rio_sim.gl import OFFSCREEN_GL

    skip_tests_without(OFFSCREEN_GL)  # without OpenGL the camera publishes flat placeholder frames
    head = teleop_run[3]
    assert head.ndim == 3 and head.std() > 5, head.shape  # the emulator is the camera's world: it renders it


@needs_sim
def test_a_recorded_t1_sim_episode_replays_to_the_same_joint_trajectory(teleop_run):
    from rio_sim.testing import check_humanoid_replay

    from rio.recording.dataset import Dataset

    _, _, root, _ = teleop_run
    ep = Dataset(root).episode(0)
    assert ep.meta["embodiment"] == "humanoid" and "head" in ep.cameras
    check_humanoid_replay(root, "t1-sim", body_dof=len(NAMES))
