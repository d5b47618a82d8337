"""rio.kinematics.multi_frame: a humanoid's two wrists solved together on the test upper body
(`rio.fakes.humanoid.UPPER_BODY_MJCF`: fixed pelvis, 3-joint legs, a waist both arms hang from, 7-joint arms)."""

from __future__ import annotations

import numpy as np
import pytest

from rio.conformance.drivers import HumanoidConformance
from rio.control import pose_error, pose_mul, rotvec_to_quat
from rio.fakes.humanoid import FakeModelHumanoid, upper_body_description, upper_body_limits
from rio.kinematics import MultiFrameIK
from rio.testing import lifecycle, skip_tests_without

skip_tests_without("mink")  # found, not imported: its import costs every test process 0.5 s

DESC = upper_body_description()
NAMES = DESC["joints"]
HOME = np.array(DESC["home"])
LOWER, UPPER = (np.array(v) for v in upper_body_limits())
LEGS = np.array(["hip" in n or "knee" in n for n in NAMES])
LEFT_ARM = [n for n in NAMES if n.startswith("left_") and not LEGS[NAMES.index(n)]]


@pytest.fixture(scope="module")
def ik() -> MultiFrameIK:
    return MultiFrameIK(DESC)


def errors(ik: MultiFrameIK, q: np.ndarray, targets: dict) -> dict[str, tuple[float, float]]:
    return {n: pose_error(ik.fk(q, n), t) for n, t in targets.items()}


def start() -> np.ndarray:
    q = HOME.copy()
    q[LEGS] = [0.3, 0.1, 0.5, -0.2, -0.1, 0.4]  # the legs somewhere: IK must leave them there
    return q


def test_solved_joints_are_the_waist_and_arms(ik):
    assert ik.solved_joints == [n for n in NAMES if not LEGS[NAMES.index(n)]]
    assert len(ik.solved_joints) == 15 and ik.dof == 21
    for side in ("left", "right"):  # home: elbows bent, wrists in front of the torso
        assert ik.fk(HOME, side)[0] > 0.25


@pytest.mark.parametrize("seed", range(4))
def test_poses_of_known_joints_are_reached_and_the_legs_stay(ik, seed):
    rng = np.random.default_rng(seed)
    q_true = start()
    q_true[~LEGS] = np.clip(HOME[~LEGS] + rng.uniform(-0.6, 0.6, (~LEGS).sum()), LOWER[~LEGS], UPPER[~LEGS])
    targets = {n: ik.fk(q_true, n) for n in ("left", "right")}
    q = start()
    for _ in range(3):  # a few teleop cycles at the same target
        q = ik.solve(targets, q)
    for name, (pe, re) in errors(ik, q, targets).items():
        assert pe < 0.005 and re < np.deg2rad(2.0), (name, pe, np.rad2deg(re))
    np.testing.assert_array_equal(q[LEGS], start()[LEGS])
    assert np.all(q >= LOWER) and np.all(q <= UPPER)


def test_one_targeted_wrist_leaves_the_other_still(ik):
    q0 = start()
    still = ik.fk(q0, "right")
    target = ik.fk(q0, "left")
    target[:3] += [0.10, 0.05, 0.08]
    q = ik.solve({"left": target}, q0, max_iters=30)
    pe, re = pose_error(ik.fk(q, "left"), target)
    assert pe < 0.005 and re < np.deg2rad(2.0)
    pe, re = pose_error(ik.fk(q, "right"), still)
    assert pe < 0.001 and re < np.deg2rad(0.5), (pe, re)


def test_position_only_frames_ignore_the_orientation(ik):
    q0 = start()
    target = ik.fk(q0, "right")
    target[:3] += [0.05, -0.05, 0.05]
    target = pose_mul(target, np.concatenate([[0, 0, 0], rotvec_to_quat([2.5, 0, 0])]))  # far beyond the wrist
    q = ik.solve({"right": target}, q0, max_iters=30, position_only={"right"})
    pe, re = pose_error(ik.fk(q, "right"), target)
    assert pe < 0.002 and re > 1.0


def test_an_unreachable_target_gets_the_best_effort_within_limits(ik):
    q0 = start()
    target = ik.fk(q0, "left")
    far = target.copy()
    far[:3] += [1.5, 1.0, 0.5]
    q = ik.solve({"left": far}, q0, max_iters=50)
    assert np.isfinite(q).all() and np.all(q >= LOWER) and np.all(q <= UPPER)
    before, after = pose_error(target, far)[0], pose_error(ik.fk(q, "left"), far)[0]
    assert after < before - 0.2  # reaching toward it
    for _ in range(3):  # more calls creep closer (toward a joint limit), never away
        q = ik.solve({"left": far}, q, max_iters=50)
        closer = pose_error(ik.fk(q, "left"), far)[0]
        assert closer <= after + 1e-4
        after = closer
    np.testing.assert_array_equal(q[LEGS], q0[LEGS])


def test_chosen_joints_and_frames():
    only_left = MultiFrameIK(DESC, frames={"hand": "left_wrist"}, joints=LEFT_ARM)
    assert only_left.solved_joints == LEFT_ARM
    q0 = start()
    target = only_left.fk(q0, "hand")
    target[:3] += [0.05, 0.0, 0.05]
    q = only_left.solve({"hand": target}, q0, max_iters=30)
    assert pose_error(only_left.fk(q, "hand"), target)[0] < 0.005
    moved = {NAMES[i] for i in np.flatnonzero(q != q0)}
    assert moved and moved <= set(LEFT_ARM)


def test_errors_name_the_frame_or_joint(ik):
    q0 = start()
    with pytest.raises(ValueError, match="no frame 'head'"):
        ik.solve({"head": ik.fk(q0, "left")}, q0)
    with pytest.raises(ValueError, match="no frame 'head'"):
        ik.fk(q0, "head")
    with pytest.raises(ValueError, match="no frame 'head'"):
        ik.solve({}, q0, position_only={"head"})
    with pytest.raises(ValueError, match="frame 'left'.*7 values"):
        ik.solve({"left": [0.1, 0.2, 0.3]}, q0)
    with pytest.raises(ValueError, match="q_current has 3 values"):
        ik.solve({}, q0[:3])
    with pytest.raises(ValueError, match="not finite"):
        ik.solve({}, np.full(21, np.nan))
    with pytest.raises(ValueError, match="joint 'neck' is not one of"):
        MultiFrameIK(DESC, joints=["neck"])
    with pytest.raises(ValueError, match="frame 'left': site 'left_hand' is not in the model"):
        MultiFrameIK({**DESC, "frames": {"left": "left_hand"}})
    with pytest.raises(ValueError, match="no frames"):
        MultiFrameIK({**DESC, "frames": {}})
    with pytest.raises(ValueError, match="format 'urdf'"):
        MultiFrameIK({**DESC, "format": "urdf"})


def test_the_fake_model_humanoid_hands_out_its_description():
    from rio.plugins import get_registry

    assert {s.name: s.kind for s in get_registry().specs("rio_drivers")}["rio.fake_model_humanoid"] == "humanoid"
    with lifecycle(FakeModelHumanoid()) as body:
        desc = body.robot_description()
        assert desc["joints"] == body.joint_names() and body.num_joints() == 21
        lower, upper = body.joint_limits()
        np.testing.assert_allclose(lower, LOWER)
        np.testing.assert_allclose(upper, UPPER)
        ik = MultiFrameIK(desc)
        np.testing.assert_allclose(ik.fk(HOME, "left")[:3] * [1, -1, 1], ik.fk(HOME, "right")[:3], atol=1e-9)


class TestFakeModelHumanoid(HumanoidConformance):
    driver = "rio.fake_model_humanoid"
