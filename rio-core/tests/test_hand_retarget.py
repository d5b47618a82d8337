"""rio.kinematics.hand_retarget: a tracked hand's keypoints to a dexterous hand's joints.

The operator's hands are made from the test hand itself: its sites' positions at known joints, shrunk
to a human's size (1/1.1) and moved to an arbitrary place in a tracker's frame, with the joints the
robot has no equivalent of filled in plausibly. Retargeting them must give back the robot's sites
where they were, and the joints too where the sites determine them.
"""

from __future__ import annotations

import numpy as np
import pytest

from rio.conformance.drivers import HandConformance
from rio.control import euler_to_quat, quat_to_matrix
from rio.fakes.hands import (
    FakeModelHand,
    five_finger_hand_description,
    five_finger_hand_joints,
    five_finger_hand_limits,
)
from rio.interfaces.teleop import HAND_JOINTS
from rio.kinematics import HandRetargeter, palm_pose
from rio.testing import lifecycle, skip_tests_without

skip_tests_without("mink")  # found, not imported: its import costs every test process 0.5 s

import mujoco  # noqa: E402

J = {name: i for i, name in enumerate(HAND_JOINTS)}
LOWER, UPPER = (np.array(v) for v in five_finger_hand_limits())
TIPS = [n for n in HAND_JOINTS if n.endswith("-tip")]
HUMAN = 1 / 1.1  # the test hand is 1.1 times a human's


def q_of(**values: float) -> np.ndarray:
    names = five_finger_hand_joints()
    q = np.zeros(len(names))
    for k, v in values.items():
        q[names.index(k)] = v
    return q


OPEN = q_of()
FIST = q_of(**{f"{f}_{j}": v for f in ("index", "middle", "ring", "pinky")
               for j, v in (("mcp", 1.3), ("pip", 1.5), ("dip", 1.0))},
            thumb_cmc_abd=0.3, thumb_cmc_flex=0.9, thumb_mcp=0.6, thumb_ip=0.7)
PINCH = q_of(thumb_cmc_abd=0.5, thumb_cmc_flex=0.8, thumb_mcp=0.3, thumb_ip=0.4,
             index_abd=0.1, index_mcp=0.7, index_pip=0.8, index_dip=0.4, middle_mcp=0.3, ring_mcp=0.2)


def rigid(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return quat_to_matrix(euler_to_quat(*rng.uniform(-np.pi, np.pi, 3))), rng.uniform(-1.0, 1.0, 3)


def model_points(desc: dict, q: np.ndarray) -> dict[str, np.ndarray]:
    """The palm and every mapped site at joints q (world frame of the model), by MuJoCo directly."""
    m = mujoco.MjModel.from_xml_string(desc["xml"])
    d = mujoco.MjData(m)
    for name, v in zip(desc["joints"], q, strict=True):
        d.qpos[m.joint(name).qposadr[0]] = v
    mujoco.mj_kinematics(m, d)
    out = {name: d.site(site).xpos.copy() for name, site in desc["keypoints"].items()}
    out["wrist"] = d.site(desc["palm"]).xpos.copy()
    out["palm_rot"] = d.site(desc["palm"]).xmat.reshape(3, 3).copy()
    return out


def operator_hand(desc: dict, q: np.ndarray, seed: int = 0, fill_rng: np.random.Generator | None = None):
    """(keypoints (25, 3) of a human-sized hand posed like the robot at q, in a tracker frame; the mapped
    sites' positions in the robot's palm frame, where the retargeted hand must put them)."""
    pts = model_points(desc, q)
    wrist, palm_rot = pts.pop("wrist"), pts.pop("palm_rot")
    in_palm = {n: (p - wrist) @ palm_rot for n, p in pts.items()}
    kp = np.zeros((len(HAND_JOINTS), 3))
    for name, p in in_palm.items():
        kp[J[name]] = HUMAN * p
    # joints the robot has no site for: on the way from the wrist to the knuckles (or anywhere, given a rng)
    for finger in ("index-finger", "middle-finger", "ring-finger", "pinky-finger"):
        kp[J[f"{finger}-metacarpal"]] = 0.3 * kp[J[f"{finger}-phalanx-proximal"]]
    kp[J["thumb-metacarpal"]] = 0.5 * kp[J["thumb-phalanx-proximal"]]
    if fill_rng is not None:
        for name in ("index-finger-metacarpal", "ring-finger-metacarpal", "thumb-metacarpal"):
            kp[J[name]] = fill_rng.uniform(-0.1, 0.1, 3)
    rot, shift = rigid(seed)
    return kp @ rot.T + shift, in_palm


def retarget(r: HandRetargeter, kp: np.ndarray, calls: int = 3) -> np.ndarray:
    for _ in range(calls):
        q = r(kp)
    return q


@pytest.fixture(scope="module")
def right() -> dict:
    return five_finger_hand_description("right")


@pytest.fixture(scope="module")
def left() -> dict:
    return five_finger_hand_description("left")


@pytest.mark.parametrize("side", ["right", "left"])
def test_the_palm_frame_of_a_hand_is_its_models_palm_site(side):
    """The convention, checked on both hands: origin at the wrist, x to the middle knuckle, z out of the
    palm (fingers curl toward +z), y = z x x toward the pinky on a right hand, the thumb on a left."""
    desc = five_finger_hand_description(side)
    for q in (OPEN, FIST):
        pts = model_points(desc, q)
        kp = np.zeros((len(HAND_JOINTS), 3))
        kp[0] = pts["wrist"]
        for name in desc["keypoints"]:
            kp[J[name]] = pts[name]
        pose = palm_pose(kp, side)
        np.testing.assert_allclose(pose[:3], pts["wrist"], atol=1e-9)
        np.testing.assert_allclose(quat_to_matrix(pose[3:]), pts["palm_rot"], atol=1e-9)
        in_palm = {n: (pts[n] - pts["wrist"]) @ pts["palm_rot"] for n in desc["keypoints"]}
        assert in_palm["middle-finger-phalanx-proximal"][0] > 0.09
        toward_pinky = in_palm["pinky-finger-phalanx-proximal"][1] - in_palm["index-finger-phalanx-proximal"][1]
        assert toward_pinky > 0 if side == "right" else toward_pinky < 0
    fist = model_points(desc, FIST)
    assert ((fist["index-finger-tip"] - fist["wrist"]) @ fist["palm_rot"])[2] > 0.03  # curled toward +z


@pytest.mark.parametrize("pose", ["open", "fist", "pinch", "random1", "random2"])
def test_an_operators_hand_is_reproduced(right, pose):
    q_true = {"open": OPEN, "fist": FIST, "pinch": PINCH}.get(pose)
    if q_true is None:
        q_true = np.random.default_rng(int(pose[-1])).uniform(LOWER, UPPER)
    kp, want = operator_hand(right, q_true, seed=len(pose))
    r = HandRetargeter(right)
    assert r.scale_for(kp) == pytest.approx(1.1)
    q = retarget(r, kp)
    assert np.all(q >= LOWER) and np.all(q <= UPPER)
    got = r.model_keypoints(q)
    for name in TIPS:
        assert np.linalg.norm(got[name] - want[name]) < 0.002, (name, got[name], want[name])
    for name in want:
        assert np.linalg.norm(got[name] - want[name]) < 0.003, name
    # every finger's knuckle, middle and distal joints are mapped: the joints are determined
    np.testing.assert_allclose(q, q_true, atol=0.02)


def test_a_left_hand_retargets_onto_the_mirrored_model(left):
    kp, want = operator_hand(left, PINCH, seed=3)
    r = HandRetargeter(left)
    q = retarget(r, kp)
    got = r.model_keypoints(q)
    assert max(np.linalg.norm(got[n] - want[n]) for n in TIPS) < 0.002
    np.testing.assert_allclose(q, PINCH, atol=0.02)
    # a left hand read as a right one is a mirror image: its palm faces the other way and it comes out wrong
    wrong = HandRetargeter({**left, "side": "right"})
    assert np.abs(retarget(wrong, kp) - PINCH).max() > 0.2


def test_the_result_depends_on_the_hand_not_on_where_the_tracker_sees_it(right):
    fill = np.random.default_rng(7)
    a, _ = operator_hand(right, FIST, seed=1)
    b, _ = operator_hand(right, FIST, seed=2, fill_rng=fill)  # elsewhere, and unmapped joints scattered
    c, _ = operator_hand(right, FIST, seed=1, fill_rng=fill)
    qa, qb, qc = (HandRetargeter(right)(kp) for kp in (a, b, c))
    np.testing.assert_allclose(qa, qb, atol=1e-6)
    np.testing.assert_allclose(qa, qc, atol=1e-6)


def test_scale_a_fixed_one_and_a_hand_mapping_tips_only(right):
    kp, want = operator_hand(right, PINCH)
    assert HandRetargeter(right, scale=0.5).scale_for(kp) == 0.5
    # a bigger operator's hand is scaled down just as much: the auto scale follows the operator
    assert HandRetargeter(right).scale_for(kp * 1.2) == pytest.approx(1.1 / 1.2)
    # the robot's own hand size, told explicitly, gives the same as the automatic scale
    np.testing.assert_allclose(retarget(HandRetargeter(right, scale=1.1), kp), retarget(HandRetargeter(right), kp),
                               atol=1e-6)
    # with fingertips alone each finger is redundant: the tips still land, the posture settles the rest
    tips = {**right, "keypoints": {n: s for n, s in right["keypoints"].items() if n.endswith("-tip")}}
    r = HandRetargeter(tips)
    assert r.scale_for(kp) == pytest.approx(1.1, rel=0.05)  # wrist to the straight middle fingertip
    got = r.model_keypoints(retarget(r, kp, calls=5))
    fixed = HandRetargeter(tips, scale=1.1)
    got_fixed = fixed.model_keypoints(retarget(fixed, kp, calls=5))
    for name in TIPS:
        assert np.linalg.norm(got_fixed[name] - want[name]) < 0.004, name
        assert np.linalg.norm(got[name] - want[name]) < 0.02, name


def test_a_slowly_moving_hand_gives_smoothly_moving_joints(right):
    r = HandRetargeter(right)
    frames = [operator_hand(right, OPEN + s * (FIST - OPEN), seed=5)[0] for s in np.linspace(0, 1, 40)]
    out = np.array([r(kp) for kp in frames])
    steps = np.abs(np.diff(out, axis=0)).max(axis=1)
    assert steps.max() < 0.15, steps  # the input moves at most 1.5/39 = 0.04 rad per joint per frame
    np.testing.assert_allclose(out[-1], FIST, atol=0.03)
    # warm start given explicitly, then forgotten
    np.testing.assert_allclose(r(frames[-1], q_prev=FIST), FIST, atol=0.03)
    r.reset()
    assert np.isfinite(r(frames[0])).all()


def test_unreachable_keypoints_give_joints_within_limits(right):
    r = HandRetargeter(right, scale=2.0)  # an operator twice the robot's size: the tips are out of reach
    kp, _ = operator_hand(right, PINCH)
    out = [r(kp) for _ in range(5)]
    for q in out:
        assert np.isfinite(q).all() and np.all(q >= LOWER) and np.all(q <= UPPER)
    assert np.abs(out[-1] - out[-2]).max() < 0.05  # settled, not oscillating


def test_bad_descriptions_and_keypoints_are_named(right):
    cases = [
        ({k: v for k, v in right.items() if k != "palm"}, "missing 'palm'"),
        ({**right, "keypoints": {**right["keypoints"], "index-tip": "index_tip"}}, "'index-tip' is not a HAND_JOINTS"),
        ({**right, "keypoints": {**right["keypoints"], "thumb-tip": "thumb_nail"}}, "site 'thumb_nail' is not in"),
        ({**right, "palm": "wrist"}, "site 'wrist' is not in the model"),
        ({**right, "side": "both"}, "side 'both'"),
        ({**right, "joints": [*right["joints"][:-1], "pinky_dop"]}, "joint 'pinky_dop' is not in the model"),
        ({**right, "format": "urdf"}, "format 'urdf'"),
        ({**right, "keypoints": {}}, "maps no joint"),
    ]
    for desc, match in cases:
        with pytest.raises(ValueError, match=match):
            HandRetargeter(desc)
    r = HandRetargeter(right)
    kp, _ = operator_hand(right, OPEN)
    bad = kp.copy()
    bad[J["thumb-tip"], 1] = np.nan
    with pytest.raises(ValueError, match="hand keypoints: not finite"):
        r(bad)
    with pytest.raises(ValueError, match=r"expected shape \(25, 3\)"):
        r(kp[:21])
    flat = kp.copy()
    flat[J["index-finger-phalanx-proximal"]] = flat[J["pinky-finger-phalanx-proximal"]]
    with pytest.raises(ValueError, match="degenerate palm"):
        r(flat)
    with pytest.raises(ValueError, match="expected 20 values"):
        r(kp, q_prev=np.zeros(3))


def test_the_fake_model_hand_hands_out_its_description():
    from rio.plugins import get_registry

    assert {s.name: s.kind for s in get_registry().specs("rio_drivers")}["rio.fake_model_hand"] == "hand"
    for side in ("right", "left"):
        with lifecycle(FakeModelHand(side=side)) as hand:
            desc = hand.robot_description()
            assert desc["joints"] == hand.joint_names() and desc["side"] == side
            lower, upper = hand.joint_limits()
            np.testing.assert_allclose(lower, LOWER)
            np.testing.assert_allclose(upper, UPPER)
            kp, _ = operator_hand(desc, FIST)
            np.testing.assert_allclose(retarget(HandRetargeter(desc), kp), FIST, atol=0.02)


class TestFakeModelHand(HandConformance):
    driver = "rio.fake_model_hand"
