"""The G1's joints as its low-level protocol numbers them: one table that the driver, the bridge and the
fallback model share, so a name always means the same motor slot on every side of the wire.

Slots 0-28 are the 29 joints in Unitree's motor order (the 23-DoF G1 uses the same slots and leaves
waist roll/pitch and wrist pitch/yaw empty); slot 29 carries the arm_sdk weight (`WEIGHT_SLOT`, the
SDK's `kNotUsedJoint`); the message has 35 slots in all.

Limits are Unitree's (the G1 29-DoF URDF/MJCF). Effort limits are the lower of the two published
hardware revisions' (hip roll 88 N·m, ankles and waist roll/pitch 35 N·m): the driver's torque band
(`rio_unitree.commands`) is then never wider than the motor. Default gains are those Unitree deploys its
29-joint G1 policy with (unitree_rl_gym, deploy_real/configs/g1.yaml): kp 100 hips, 150 knees, 40
ankles, 150 waist, 100 shoulder pitch/roll, 50 shoulder yaw and elbow, 20 wrists; kd 2 (knees 4, waist
3, wrists 1). Damping (kp = 0) uses kd 2 on hips and waist, 3 on knees, 1 on ankles and arms, 0.5 on
wrists. A station overrides any of them per joint (`kp`, `kd`, `damping_kd`).
"""

from __future__ import annotations

from dataclasses import dataclass

from .joint_table import pick

NUM_SLOTS = 35
#: motor_cmd[29].q on rt/arm_sdk: how much of the arm/waist command Unitree's controller takes (0..1).
WEIGHT_SLOT = 29


@dataclass(frozen=True)
class Joint:
    name: str
    slot: int
    lower: float
    upper: float
    effort: float  # N·m
    kp: float
    kd: float
    damping: float  # kd of the damping command (kp = 0)


def _j(name: str, slot: int, lo: float, hi: float, effort: float, kp: float, kd: float, damp: float) -> Joint:
    return Joint(name, slot, lo, hi, effort, kp, kd, damp)


def _leg(side: str, base: int) -> list[Joint]:
    roll = (-0.5236, 2.9671) if side == "left" else (-2.9671, 0.5236)
    return [
        _j(f"{side}_hip_pitch_joint", base, -2.5307, 2.8798, 88, 100, 2, 2),
        _j(f"{side}_hip_roll_joint", base + 1, *roll, 88, 100, 2, 2),
        _j(f"{side}_hip_yaw_joint", base + 2, -2.7576, 2.7576, 88, 100, 2, 2),
        _j(f"{side}_knee_joint", base + 3, -0.087267, 2.8798, 139, 150, 4, 3),
        _j(f"{side}_ankle_pitch_joint", base + 4, -0.87267, 0.5236, 35, 40, 2, 1),
        _j(f"{side}_ankle_roll_joint", base + 5, -0.2618, 0.2618, 35, 40, 2, 1),
    ]


def _arm(side: str, base: int) -> list[Joint]:
    roll = (-1.5882, 2.2515) if side == "left" else (-2.2515, 1.5882)
    return [
        _j(f"{side}_shoulder_pitch_joint", base, -3.0892, 2.6704, 25, 100, 2, 1),
        _j(f"{side}_shoulder_roll_joint", base + 1, *roll, 25, 100, 2, 1),
        _j(f"{side}_shoulder_yaw_joint", base + 2, -2.618, 2.618, 25, 50, 2, 1),
        _j(f"{side}_elbow_joint", base + 3, -1.0472, 2.0944, 25, 50, 2, 1),
        _j(f"{side}_wrist_roll_joint", base + 4, -1.972222054, 1.972222054, 25, 20, 1, 0.5),
        _j(f"{side}_wrist_pitch_joint", base + 5, -1.614429558, 1.614429558, 5, 20, 1, 0.5),
        _j(f"{side}_wrist_yaw_joint", base + 6, -1.614429558, 1.614429558, 5, 20, 1, 0.5),
    ]


JOINTS: tuple[Joint, ...] = (
    *_leg("left", 0), *_leg("right", 6),
    _j("waist_yaw_joint", 12, -2.618, 2.618, 88, 150, 3, 2),
    _j("waist_roll_joint", 13, -0.52, 0.52, 35, 150, 3, 2),
    _j("waist_pitch_joint", 14, -0.52, 0.52, 35, 150, 3, 2),
    *_arm("left", 15), *_arm("right", 22),
)
BY_NAME = {j.name: j for j in JOINTS}

#: Slots the 23-DoF G1 does not have (waist roll/pitch, wrist pitch/yaw).
_MISSING_23 = {13, 14, 20, 21, 27, 28}
#: Waist and arms: what rt/arm_sdk drives (the legs stay with Unitree's locomotion).
UPPER_BODY_SLOTS = frozenset(range(12, 29))


def joint_names(dof: int = 29, upper_body_only: bool = False) -> list[str]:
    """The joints of a `dof`-joint G1 in slot order (only waist and arms with `upper_body_only`)."""
    if dof not in (23, 29):
        raise ValueError(f"a G1 has 23 or 29 joints, not {dof}")
    out = []
    for j in JOINTS:
        if dof == 23 and j.slot in _MISSING_23:
            continue
        if upper_body_only and j.slot not in UPPER_BODY_SLOTS:
            continue
        out.append(j.name)
    return out


def lookup(names: list[str]) -> list[Joint]:
    return pick(JOINTS, names, "G1")


#: A relaxed stand for a hanging or standing robot: knees slightly bent, elbows bent (rad; 0 elsewhere).
HOME = {"left_hip_pitch_joint": -0.1, "right_hip_pitch_joint": -0.1, "left_knee_joint": 0.3,
        "right_knee_joint": 0.3, "left_ankle_pitch_joint": -0.2, "right_ankle_pitch_joint": -0.2,
        "left_shoulder_roll_joint": 0.2, "right_shoulder_roll_joint": -0.2, "left_elbow_joint": 1.0,
        "right_elbow_joint": 1.0}
