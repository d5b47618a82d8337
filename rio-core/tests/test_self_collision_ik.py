"""rio.kinematics.MultiFrameIK's self-collision avoidance on the test upper body (`rio.fakes.humanoid.UPPER_BODY_MJCF`:
capsule links, a torso capsule both arms hang from). Distances are measured here on a model of our own with
MuJoCo's `mj_geomDistance`, not through the IK's bookkeeping."""

from __future__ import annotations

import numpy as np
import pytest

from rio.control import pose_error
from rio.fakes.humanoid import UPPER_BODY_MJCF, upper_body_description
from rio.kinematics import MultiFrameIK
from rio.kinematics.self_collision import SLIP, collision_geoms
from rio.testing import skip_tests_without

skip_tests_without("mink")  # found, not imported: its import costs every test process 0.5 s
mujoco = pytest.importorskip("mujoco")

DESC = upper_body_description()
NAMES = DESC["joints"]
HOME = np.array(DESC["home"])
LEGS = np.array(["hip" in n or "knee" in n for n in NAMES])
MIN = 0.01  # MultiFrameIK's default min_distance
ARM_LINKS = ("shoulder_pitch_link", "elbow_link", "wrist_yaw_link")
TRUNK = ("pelvis", "torso", "left_hip_pitch_link", "left_knee_link", "right_hip_pitch_link", "right_knee_link")
MODEL = mujoco.MjModel.from_xml_string(UPPER_BODY_MJCF)


def arm(side: str) -> list[str]:
    return [f"{side}_{link}" for link in ARM_LINKS]


def gap(q: np.ndarray, bodies_a: list[str] | tuple[str, ...], bodies_b: list[str] | tuple[str, ...]) -> float:
    """The smallest signed distance between the geoms of two sets of bodies at the node's joints `q`."""
    data = mujoco.MjData(MODEL)
    for name, value in zip(NAMES, q, strict=True):
        data.qpos[MODEL.joint(name).qposadr[0]] = value
    mujoco.mj_kinematics(MODEL, data)
    geoms = [[g for g in range(MODEL.ngeom) if MODEL.body(MODEL.geom_bodyid[g]).name in names]
             for names in (bodies_a, bodies_b)]
    return min(mujoco.mj_geomDistance(MODEL, data, a, b, 1.0, None) for a in geoms[0] for b in geoms[1])


def body_pairs(ik: MultiFrameIK) -> set[frozenset[str]]:
    m = ik.model
    return {frozenset(m.body(m.geom_bodyid[g]).name for g in pair) for pair in ik.collision_pairs}


@pytest.fixture(scope="module")
def ik() -> MultiFrameIK:
    return MultiFrameIK(DESC)


@pytest.fixture(scope="module")
def ik_off() -> MultiFrameIK:
    return MultiFrameIK({**DESC, "self_collision": False})


def run(ik: MultiFrameIK, targets: dict, cycles: int, watch: tuple) -> tuple[np.ndarray, float]:
    """Teleop cycles at fixed targets; the joints at the end and the nearest the watched bodies came."""
    q, nearest = HOME.copy(), np.inf
    for _ in range(cycles):
        q = ik.solve(targets, q)
        nearest = min(nearest, gap(q, *watch))
    return q, nearest


def test_default_pairs_are_each_arm_against_the_body_and_the_other_arm(ik):
    pairs = body_pairs(ik)
    for side, other in (("left", "right"), ("right", "left")):
        for link in arm(side):
            for obstacle in (*TRUNK, *arm(other)):
                near_joint = link.endswith("shoulder_pitch_link") and obstacle == "torso"
                assert (frozenset((link, obstacle)) in pairs) != near_joint, (link, obstacle)
        for a in arm(side):  # an arm is not avoided against itself
            assert not any(frozenset((a, b)) in pairs for b in arm(side))
    assert frozenset(("torso", "pelvis")) not in pairs and frozenset(("pelvis", "left_knee_link")) not in pairs


def test_a_target_inside_the_torso_stops_the_hand_at_its_surface(ik, ik_off):
    target = np.array([0.0, 0.03, 1.2, 1.0, 0.0, 0.0, 0.0])  # the torso's axis: 10 cm inside its capsule
    watch = (arm("left"), ("torso",))
    q, nearest = run(ik, {"left": target}, 20, watch)
    assert nearest >= MIN - SLIP - 1e-6, nearest
    assert gap(q, *watch) < MIN + 0.005  # pressed against it, not held off far away
    np.testing.assert_array_equal(q[LEGS], HOME[LEGS])
    q_off, _ = run(ik_off, {"left": target}, 20, watch)
    assert gap(q_off, *watch) < -0.05  # without avoidance the arm goes right into the torso


def test_crossing_hands_keep_the_arms_apart(ik, ik_off):
    targets = {"left": ik.fk(HOME, "right"), "right": ik.fk(HOME, "left")}  # swapped: the arms would cross
    watch = (arm("left"), arm("right"))
    _, nearest = run(ik, targets, 40, watch)
    assert nearest >= MIN - SLIP - 1e-6, nearest
    q_off, _ = run(ik_off, targets, 40, watch)
    assert gap(q_off, *watch) < 0.0


def test_sliding_along_the_torso_still_follows_the_target(ik):
    """Pressed against the torso, the hand still tracks a target moving along it (limbs do not stick)."""
    q, target = HOME.copy(), np.array([0.0, 0.05, 1.25, 1.0, 0.0, 0.0, 0.0])
    for k in range(140):
        target[2] = 1.25 - 0.2 * max(0, k - 40) / 100
        q = ik.solve({"left": target}, q, position_only={"left"})
        assert gap(q, arm("left"), ("torso",)) >= MIN - SLIP - 1e-6
    assert abs(ik.fk(q, "left")[2] - 1.05) < 0.01


@pytest.mark.parametrize("seed", range(4))
def test_poses_away_from_the_body_are_reached_as_without_avoidance(ik, seed):
    """Wrist poses of random arm joints whose links stay 3 cm clear of each other and the body: reached
    within 5 mm / 2 degrees in three cycles, as without avoidance (test_multi_frame_ik), legs untouched."""
    rng = np.random.default_rng(seed)
    lower, upper = (np.array(v) for v in (ik.lower, ik.upper))
    everything = [*arm("left"), *arm("right"), *TRUNK]
    while True:
        q_true = HOME.copy()
        q_true[~LEGS] = np.clip(HOME[~LEGS] + rng.uniform(-0.6, 0.6, (~LEGS).sum()), lower[~LEGS], upper[~LEGS])
        if min(gap(q_true, arm(s), [b for b in everything if b not in arm(s)]) for s in ("left", "right")) > 0.03:
            break
    targets = {s: ik.fk(q_true, s) for s in ("left", "right")}
    q0 = HOME.copy()
    q0[LEGS] = [0.3, 0.1, 0.5, -0.2, -0.1, 0.4]
    q = q0
    for _ in range(3):
        q = ik.solve(targets, q)
    for side, target in targets.items():
        pe, re = pose_error(ik.fk(q, side), target)
        assert pe < 0.005 and re < np.deg2rad(2.0), (side, pe, np.rad2deg(re))
    np.testing.assert_array_equal(q[LEGS], q0[LEGS])


def test_named_pairs_replace_the_default_and_the_switch_turns_it_off(ik_off):
    named = MultiFrameIK({**DESC, "collision_pairs": [[["left_elbow_link", "left_wrist_yaw_link"], ["torso"]]]})
    assert body_pairs(named) == {frozenset(("left_elbow_link", "torso")), frozenset(("left_wrist_yaw_link", "torso"))}
    assert ik_off.collision_pairs == [] and ik_off.clearance(HOME) == 1.0
    # the right arm is not in the pairs: it may go into the torso
    q, _ = run(named, {"right": np.array([0.0, -0.03, 1.2, 1.0, 0.0, 0.0, 0.0])}, 20, (arm("right"), ("torso",)))
    assert gap(q, arm("right"), ("torso",)) < -0.05


def test_pairs_touching_at_home_or_at_a_joint_are_left_out():
    """The upper arm hangs 5 cm from the torso and is the torso's child: neither pair is kept."""
    named = MultiFrameIK({**DESC, "collision_pairs": [[["left_shoulder_pitch_link"], ["torso", "pelvis"]]]})
    assert body_pairs(named) == {frozenset(("left_shoulder_pitch_link", "pelvis"))}
    far = MultiFrameIK({**DESC, "collision_pairs": [[["left_shoulder_pitch_link"], ["pelvis"]]]}, min_distance=0.3,
                       detection_distance=0.4)
    assert far.collision_pairs == []  # 0.3 m is more than the pelvis is from the upper arm at home


def test_visual_geoms_are_left_out_and_a_visual_only_model_uses_every_geom():
    visual = UPPER_BODY_MJCF.replace('<geom type="capsule" fromto="0 0 0 0 0 0.35" size="0.1"/>',
                                     '<geom type="capsule" fromto="0 0 0 0 0 0.35" size="0.1"/>'
                                     '<geom name="logo" type="sphere" size="0.3" contype="0" conaffinity="0"/>')
    ik = MultiFrameIK({**DESC, "xml": visual})
    logo = ik.model.geom("logo").id
    assert not collision_geoms(ik.model)[logo] and all(logo not in p for p in ik.collision_pairs)
    only_visual = UPPER_BODY_MJCF.replace("<geom ", '<geom contype="0" conaffinity="0" ')
    ik = MultiFrameIK({**DESC, "xml": only_visual})
    assert body_pairs(ik) == body_pairs(MultiFrameIK(DESC))
    _, nearest = run(ik, {"left": np.array([0.0, 0.03, 1.2, 1.0, 0.0, 0.0, 0.0])}, 20, (arm("left"), ("torso",)))
    assert nearest >= MIN - SLIP - 1e-6


def test_bad_collision_settings_name_what_is_wrong():
    with pytest.raises(ValueError, match=r"collision_pairs\[0\]: 'elbow' is neither a geom nor a body"):
        MultiFrameIK({**DESC, "collision_pairs": [[["elbow"], ["torso"]]]})
    with pytest.raises(ValueError, match=r"collision_pairs\[1\]: write two lists"):
        MultiFrameIK({**DESC, "collision_pairs": [[["torso"], ["pelvis"]], ["torso"]]})
    with pytest.raises(ValueError, match=r"collision_pairs\[0\]: write two lists"):
        MultiFrameIK({**DESC, "collision_pairs": [["torso", "pelvis"]]})
    with pytest.raises(ValueError, match="min_distance 0.05 and detection_distance 0.05"):
        MultiFrameIK(DESC, min_distance=0.05)
