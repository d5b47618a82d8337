"""The Booster T1's joints as its low-level API numbers them: one table the driver and the emulator share.

Order: the SDK's `JointIndex` (23 joints, `kJointCnt`), which is also the joint order of Booster's T1
model (the `T1_23dof` URDF, and MuJoCo Menagerie's `booster_t1/t1.xml` made from it): head yaw/pitch,
left arm (shoulder pitch, shoulder roll, elbow pitch, elbow yaw), right arm, waist, left leg (hip pitch,
roll, yaw, knee, ankle pitch, ankle roll), right leg. The SDK calls the last two of each leg
`kCrankUp*`/`kCrankDown*` (the two motors of the parallel ankle); in SERIAL commands and
`motor_state_serial` they are the ankle's pitch and roll joints. The names are the model's.

Limits and effort limits (N·m) are those of Booster's model (joint `range`, `actuatorfrcrange`). The
T1 with 7-DoF arms (`kJointCnt7DofArm` = 29, `JointIndexWith7DofArm`) is not in this table.

Default gains (per joint, a station overrides any of them: `kp`, `kd`, `damping_kd`), ours, chosen
conservative: kp 10 / kd 0.5 on the head (7 N·m motors), kp 40 / kd 2 on the arms (the SDK's own
low-level example moves the arms with kp 40, kd 3), kp 100 / kd 3 on the waist and hips, kp 150 / kd 4
on the knees, kp 40 / kd 2 on the ankles. Damping (kp = 0) uses kd 0.5 head, 1 arms, 3 waist and hips,
4 knees, 1 ankles.
"""

from __future__ import annotations

from dataclasses import dataclass

NUM_JOINTS = 23


@dataclass(frozen=True)
class Joint:
    name: str
    index: int  # the SDK's JointIndex
    lower: float
    upper: float
    effort: float  # N·m
    kp: float
    kd: float
    damping: float  # kd of the damping command (kp = 0)


_HEAD = (10.0, 0.5, 0.5)
_ARM = (40.0, 2.0, 1.0)
_HIP = (100.0, 3.0, 3.0)
_KNEE = (150.0, 4.0, 4.0)
_ANKLE = (40.0, 2.0, 1.0)


def _arm(side: str, roll: tuple[float, float], elbow_yaw: tuple[float, float]) -> list[tuple]:
    return [(f"{side}_Shoulder_Pitch", -3.31, 1.22, 18, *_ARM), (f"{side}_Shoulder_Roll", *roll, 18, *_ARM),
            (f"{side}_Elbow_Pitch", -2.27, 2.27, 18, *_ARM), (f"{side}_Elbow_Yaw", *elbow_yaw, 18, *_ARM)]


def _leg(side: str, roll: tuple[float, float]) -> list[tuple]:
    return [(f"{side}_Hip_Pitch", -1.8, 1.57, 45, *_HIP), (f"{side}_Hip_Roll", *roll, 30, *_HIP),
            (f"{side}_Hip_Yaw", -1.0, 1.0, 30, *_HIP), (f"{side}_Knee_Pitch", 0.0, 2.34, 60, *_KNEE),
            (f"{side}_Ankle_Pitch", -0.87, 0.35, 20, *_ANKLE), (f"{side}_Ankle_Roll", -0.44, 0.44, 15, *_ANKLE)]


_ROWS = [
    ("AAHead_yaw", -1.57, 1.57, 7, *_HEAD), ("Head_pitch", -0.35, 1.22, 7, *_HEAD),
    *_arm("Left", (-1.74, 1.57), (-2.44, 0.0)), *_arm("Right", (-1.57, 1.74), (0.0, 2.44)),
    ("Waist", -1.57, 1.57, 30, *_HIP),
    *_leg("Left", (-0.2, 1.57)), *_leg("Right", (-1.57, 0.2)),
]
JOINTS: tuple[Joint, ...] = tuple(Joint(name, i, lo, hi, float(eff), kp, kd, damp)
                                  for i, (name, lo, hi, eff, kp, kd, damp) in enumerate(_ROWS))
BY_NAME = {j.name: j for j in JOINTS}

#: The SDK's JointIndex member of each joint, in order (checked against the SDK by the tests).
SDK_INDEX_NAMES = (
    "kHeadYaw", "kHeadPitch", "kLeftShoulderPitch", "kLeftShoulderRoll", "kLeftElbowPitch", "kLeftElbowYaw",
    "kRightShoulderPitch", "kRightShoulderRoll", "kRightElbowPitch", "kRightElbowYaw", "kWaist",
    "kLeftHipPitch", "kLeftHipRoll", "kLeftHipYaw", "kLeftKneePitch", "kCrankUpLeft", "kCrankDownLeft",
    "kRightHipPitch", "kRightHipRoll", "kRightHipYaw", "kRightKneePitch", "kCrankUpRight", "kCrankDownRight",
)

#: The stand of Booster's model (its "home" keyframe): arms down at the sides, knees bent (rad; 0 elsewhere).
HOME = {"Left_Shoulder_Roll": -1.4, "Left_Elbow_Yaw": -0.4, "Right_Shoulder_Roll": 1.4, "Right_Elbow_Yaw": 0.4,
        "Left_Hip_Pitch": -0.2, "Left_Knee_Pitch": 0.4, "Left_Ankle_Pitch": -0.2,
        "Right_Hip_Pitch": -0.2, "Right_Knee_Pitch": 0.4, "Right_Ankle_Pitch": -0.2}


def joint_names() -> list[str]:
    return [j.name for j in JOINTS]


def lookup(names: list[str]) -> list[Joint]:
    unknown = [n for n in names if n not in BY_NAME]
    if unknown:
        raise ValueError(f"unknown T1 joints {unknown}; the T1's are {joint_names()}")
    return [BY_NAME[n] for n in names]


def home_pose(names: list[str] | None = None) -> list[float]:
    return [HOME.get(n, 0.0) for n in (names or joint_names())]
