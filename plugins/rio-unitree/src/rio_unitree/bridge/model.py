"""Which G1 model the bridge simulates, and where its joints and its IMU are in MuJoCo's arrays.

rio-sim ships a G1 (`rio_sim/assets/g1.xml`, the 29 joints named as Unitree's URDF); the bridge uses
it when rio-sim is installed and has it (looked up at run time, so the plugin works without it).
Otherwise, and in this plugin's tests (which must not depend on rio-sim's model), it builds a small
G1-like model here: the same 29 hinge joints in Unitree's motor order, limits and effort limits from
`rio_unitree.g1`, capsule links of about the G1's lengths and masses (35 kg), the pelvis welded to the
world ("mounted", as a G1 hangs on its gantry) or free above a floor.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import dex3
from ..g1 import BY_NAME, JOINTS

# (body, joint axis, offset from the parent body, link vector to the next body (a capsule), mass kg, armature)
_Y, _X, _Z = "0 1 0", "1 0 0", "0 0 1"
Link = tuple[str, str, tuple, tuple, float, float]


def _leg(side: str, s: float) -> list[Link]:
    return [
        (f"{side}_hip_pitch_link", _Y, (0, s * 0.0645, -0.1027), (0, s * 0.052, -0.03), 1.35, 0.02),
        (f"{side}_hip_roll_link", _X, (0, s * 0.052, -0.03), (0.025, 0, -0.124), 1.52, 0.02),
        (f"{side}_hip_yaw_link", _Z, (0.025, 0, -0.124), (-0.078, 0, -0.177), 1.70, 0.02),
        (f"{side}_knee_link", _Y, (-0.078, 0, -0.177), (0, 0, -0.30), 1.93, 0.03),
        (f"{side}_ankle_pitch_link", _Y, (0, 0, -0.30), (0, 0, -0.018), 0.07, 0.01),
        (f"{side}_ankle_roll_link", _X, (0, 0, -0.018), (0.12, 0, -0.03), 0.61, 0.01),
    ]


def _arm(side: str, s: float) -> list[Link]:
    return [
        (f"{side}_shoulder_pitch_link", _Y, (0.004, s * 0.10, 0.238), (0, s * 0.038, -0.014), 0.72, 0.01),
        (f"{side}_shoulder_roll_link", _X, (0, s * 0.038, -0.014), (0, 0, -0.10), 0.64, 0.01),
        (f"{side}_shoulder_yaw_link", _Z, (0, 0, -0.10), (0.016, 0, -0.08), 0.73, 0.01),
        (f"{side}_elbow_link", _Y, (0.016, 0, -0.08), (0.10, 0, -0.01), 0.60, 0.01),
        (f"{side}_wrist_roll_link", _X, (0.10, 0, -0.01), (0.038, 0, 0), 0.09, 0.01),
        (f"{side}_wrist_pitch_link", _Y, (0.038, 0, 0), (0.046, 0, 0), 0.48, 0.01),
        (f"{side}_wrist_yaw_link", _Z, (0.046, 0, 0), (0.10, 0, 0), 0.55, 0.01),  # with a rubber hand
    ]


_WAIST: list[Link] = [
    ("waist_yaw_link", _Z, (0, 0, 0), (-0.004, 0, 0.035), 0.24, 0.02),
    ("waist_roll_link", _X, (-0.004, 0, 0.035), (0, 0, 0.019), 0.05, 0.02),
    ("torso_link", _Y, (0, 0, 0.019), (0, 0, 0.30), 9.6, 0.02),  # the waist pitch joint moves the torso
]


def _fmt(v: Any) -> str:
    return " ".join(f"{float(x):.4g}" for x in v)


def _chain(links: list[Link], tip: str = "") -> str:
    """Nested bodies, one G1 joint each (limits and effort from `rio_unitree.g1`), `tip` in the last."""
    xml = ""
    for body, axis, pos, link, mass, armature in links:
        j = BY_NAME["waist_pitch_joint" if body == "torso_link" else body.replace("_link", "_joint")]
        size = 0.09 if body == "torso_link" else 0.03
        xml += (f'<body name="{body}" pos="{_fmt(pos)}"><joint name="{j.name}" axis="{axis}" '
                f'range="{j.lower} {j.upper}" actuatorfrcrange="{-j.effort} {j.effort}" armature="{armature}" '
                f'damping="0.1"/><geom type="capsule" fromto="0 0 0 {_fmt(link)}" size="{size}" mass="{mass}"/>')
    return xml + tip + "</body>" * len(links)


def _foot(side: str) -> str:
    return f'<geom name="{side}_foot" type="box" pos="0.035 0 -0.03" size="0.1 0.035 0.01" mass="0.01"/>'


def fallback_mjcf(mounted: bool = True) -> str:
    """A G1-like model (see the module docstring); `mounted`: pelvis welded to the world at 0.793 m."""
    legs = "".join(_chain(_leg(side, s), _foot(side)) for side, s in (("left", 1.0), ("right", -1.0)))
    arms = "".join(_chain(_arm(side, s), f'<site name="{side}_hand" pos="0.1 0 0"/>')
                   for side, s in (("left", 1.0), ("right", -1.0)))
    torso = _chain(_WAIST, f'<site name="torso_imu" pos="-0.04 0 0.14"/>{arms}')
    base = "" if mounted else '<freejoint name="floating_base_joint"/>'
    floor = "" if mounted else '<geom name="floor" type="plane" size="5 5 0.1" contype="1" conaffinity="2"/>'
    robot = 'contype="0" conaffinity="0"' if mounted else 'contype="2" conaffinity="1"'  # the floor, not itself
    return ('<mujoco model="rio-unitree-g1"><compiler angle="radian" autolimits="true"/>'
            f'<option timestep="0.002"/><default><geom {robot}/></default>'
            f'<worldbody>{floor}<body name="pelvis" pos="0 0 0.793">{base}'
            '<geom type="box" size="0.06 0.11 0.06" pos="0 0 -0.05" mass="3.8"/>'
            f'<site name="imu" pos="0 0 0"/>{legs}{torso}</body></worldbody></mujoco>')


FALLBACK = "fallback"
#: `model = "hands"`: rio-sim's G1 with its two Dex3-1 hands (the bridge then serves rt/dex3/*).
HANDS = "hands"


def rio_sim_asset(hands: bool = False) -> Path | None:
    """rio-sim's G1 model (with its Dex3-1 hands: `hands`), when rio-sim is installed and ships one."""
    spec = importlib.util.find_spec("rio_sim")
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(next(iter(spec.submodule_search_locations))) / "assets" / ("g1_hands.xml" if hands else "g1.xml")
    return path if path.is_file() else None


@dataclass
class HandModel:
    """One Dex3-1 in the model: its joints in motor order (HandCmd index 0-6)."""

    side: str
    qpos: np.ndarray
    dof: np.ndarray
    act: np.ndarray


@dataclass
class G1Model:
    """A loaded model and the G1's joints in it, in motor-slot order."""

    model: Any
    data: Any
    source: str
    slots: np.ndarray  # motor slot of each joint found
    qpos: np.ndarray  # qpos address of each
    dof: np.ndarray  # dof address of each
    act: np.ndarray  # its motor (actuator id)
    effort: np.ndarray
    pelvis: int
    free: bool  # the pelvis has a free joint (qpos[0:7] its pose)
    hands: dict[str, HandModel]  # the Dex3-1 hands the model has (all seven joints of a side), by side


def load(path: str | Path | None = None, mounted: bool = True) -> G1Model:
    """The MJCF at `path`; None: rio-sim's G1, else the fallback model; "fallback": the fallback model.

    The file's actuators are replaced by one motor per G1 joint whose force is affine in the joint's
    position and velocity (force = ctrl - kp q - kd dq, limited to the joint's effort): the bridge sets
    kp, kd and ctrl from each command, so Unitree's PD law runs inside MuJoCo's step, its damping
    integrated implicitly (`implicitfast`), and a stiff kd on a light wrist stays stable at 500 Hz as it
    does in the robot's motor drivers."""
    import mujoco

    if str(path) == HANDS:
        path = rio_sim_asset(hands=True)
        if path is None:
            raise ValueError("model 'hands' is rio-sim's G1 with Dex3-1 hands: install rio-sim "
                             "(pip install 'rio-unitree[sim]')")
    if path is None:
        path = rio_sim_asset()
    if path is None or str(path) == FALLBACK:
        spec, source = mujoco.MjSpec.from_string(fallback_mjcf(mounted)), "fallback"
    else:
        spec, source = mujoco.MjSpec.from_file(str(path)), str(path)
    if mounted:  # weld the pelvis: a file's free joint goes
        for joint in list(spec.joints):
            if joint.type == mujoco.mjtJoint.mjJNT_FREE:
                spec.delete(joint)
    for act in list(spec.actuators):
        spec.delete(act)
    found = []
    for j in JOINTS:
        joint = spec.joint(j.name)
        if joint is None:
            continue
        found.append((j.slot, j.name, _motor(spec, j.name, j.effort)))
    if not found:
        raise ValueError(f"{source} has none of the G1's joints ({JOINTS[0].name}, ...)")
    hand_joints = {}
    for side in dex3.SIDES:
        table = dex3.joints(side)
        if not all(spec.joint(j.name) is not None for j in table):
            continue
        hand_joints[side] = [j.name for j in table]
        for j in table:
            _motor(spec, j.name, j.effort)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    model = spec.compile()
    pelvis = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "pelvis")
    if pelvis < 0:
        raise ValueError(f"{source} has no body named 'pelvis' (where the G1's IMU is)")
    jnt = model.body_jntadr[pelvis]
    free = jnt >= 0 and model.jnt_type[jnt] == mujoco.mjtJoint.mjJNT_FREE
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for _, name, _ in found]
    acts = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{name}_motor") for _, name, _ in found]
    hands = {}
    for side, names in hand_joints.items():
        jids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in names]
        hands[side] = HandModel(side, np.array([model.jnt_qposadr[j] for j in jids]),
                                np.array([model.jnt_dofadr[j] for j in jids]),
                                np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{n}_motor")
                                          for n in names]))
    return G1Model(model, mujoco.MjData(model), source, np.array([s for s, _, _ in found]),
                   np.array([model.jnt_qposadr[j] for j in ids]), np.array([model.jnt_dofadr[j] for j in ids]),
                   np.array(acts), np.array([e for _, _, e in found], np.float64), pelvis, bool(free), hands)


def _motor(spec: Any, joint_name: str, default_effort: float) -> float:
    """Add the affine motor of `joint_name` (see `load`); its effort limit (the file's where it has one)."""
    import mujoco

    lo, hi = spec.joint(joint_name).actfrcrange
    effort = float(hi) if hi > lo else default_effort
    act = spec.add_actuator()
    act.name, act.target, act.trntype = f"{joint_name}_motor", joint_name, mujoco.mjtTrn.mjTRN_JOINT
    act.gaintype, act.biastype = mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtBias.mjBIAS_AFFINE
    act.gainprm[0] = 1.0
    act.forcelimited, act.forcerange = mujoco.mjtLimited.mjLIMITED_TRUE, [-effort, effort]
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    return effort
