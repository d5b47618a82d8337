"""The Booster T1 of rio-sim: what its driver (`sim.t1`) and scenes need to know about `assets/t1.xml`
(23 DoF, transcribed from Booster's model in MuJoCo Menagerie; see its header). Joint and actuator names
and order are Booster's SDK `JointIndex` order, a contract shared with `rio_booster.t1` (whose table the
names are copied from: rio-sim must not import a vendor plugin; `tests/test_t1.py` checks that they
agree when rio-booster is installed).

Servo gains (kp N m/rad, kd N m s/rad) are rio-booster's defaults for the real T1 (conservative, its
README): 10/0.5 on the head, 40/2 on the arms, 100/3 on the waist and hips, 150/4 on the knees, 40/2 on
the ankles. As on the G1, a mounted T1 gets each joint's gravity torque as a feed-forward (MuJoCo's
`gravcomp` through the actuators), a free-floating one none.

The T1's arms have four joints and no wrist: a hand can be put where the operator's hand goes but cannot
also keep its orientation, so its description asks the wrists' IK for position first (`IK`).
"""

from __future__ import annotations

from functools import cache

from .robots import ASSETS

ASSET = "t1.xml"
#: The root body, on `FREE_JOINT` when the scene does not mount it.
BASE, FREE_JOINT = "Trunk", "floating_base_joint"

_ARM = ("Shoulder_Pitch", "Shoulder_Roll", "Elbow_Pitch", "Elbow_Yaw")
_LEG = ("Hip_Pitch", "Hip_Roll", "Hip_Yaw", "Knee_Pitch", "Ankle_Pitch", "Ankle_Roll")
#: Booster's JointIndex order (LowCmd/LowState `motor_state_serial` indices 0-22), as in rio_booster.t1.
JOINTS: tuple[str, ...] = (
    "AAHead_yaw", "Head_pitch", *(f"Left_{j}" for j in _ARM), *(f"Right_{j}" for j in _ARM), "Waist",
    *(f"Left_{j}" for j in _LEG), *(f"Right_{j}" for j in _LEG),
)

#: (kp, kd) per joint group; see the module docstring.
GAINS: dict[str, tuple[float, float]] = {"head": (10.0, 0.5), "arms": (40.0, 2.0), "waist": (100.0, 3.0),
                                         "hips": (100.0, 3.0), "knees": (150.0, 4.0), "ankles": (40.0, 2.0)}


def group(joint: str) -> str:
    """The gain group of a joint: head, arms, waist, hips, knees or ankles."""
    for key, name in (("Head", "head"), ("Waist", "waist"), ("Hip", "hips"), ("Knee", "knees"),
                      ("Ankle", "ankles")):
        if key in joint:
            return name
    return "arms"


#: Home: the legs of Booster's stand (Menagerie's "home" key: hip pitch -0.2, knee 0.4, ankle pitch -0.2);
#: the arms raised forward with the elbows bent a right angle inward, so both hands are in front of the
#: trunk, over the table, instead of Booster's arms down at the sides. Left-side values; the right side
#: mirrors the rolls and yaws (about x and z;
#: the pitches are about y, the mirror's normal).
_HOME = {"Hip_Pitch": -0.2, "Knee_Pitch": 0.4, "Ankle_Pitch": -0.2,
         "Shoulder_Pitch": -0.8, "Shoulder_Roll": -1.4, "Elbow_Pitch": 0.3, "Elbow_Yaw": -1.4}
#: Trunk height (m above the floor) at home with both soles on the floor (tests check it).
STANDING_HEIGHT = 0.667


def home() -> list[float]:
    """The home pose, in `JOINTS` order (rad)."""
    out = []
    for joint in JOINTS:
        side, _, name = joint.partition("_")
        value = _HOME.get(name, 0.0)
        out.append(-value if side == "Right" and name in ("Shoulder_Roll", "Elbow_Yaw") else value)
    return out


#: The hands' tool frames (sites), as `robot_description()` names them.
FRAMES = {"left": "left_hand_tool", "right": "right_hand_tool"}
#: What the wrists' IK is asked beyond the frames (module docstring): the hands' orientation weighs 1/100
#: of their position (`rio.kinematics.MultiFrameIK`'s orientation_cost).
IK = {"orientation_cost": 0.01}


@cache
def asset_text(hands: bool = False) -> str:
    if hands:
        raise ValueError("the T1 model has no dexterous hands (hands = false)")
    return (ASSETS / ASSET).read_text(encoding="utf-8")
