"""The kinematic models of the UFACTORY arms: each MJCF's tool site follows UFACTORY's published D-H
forward kinematics, sits where the controllers report the TCP at zero joints, its joints carry the
controller's limits, each home pose points the tool down in front of the base, and the robot
description drives RIO's shared kinematics (FK and IK) for every model."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rio_ufactory.description import description
from rio_ufactory.models import ARMS, get_arm, model_of

mujoco = pytest.importorskip("mujoco")

pi = math.pi
_T2 = -math.atan(284.5 / 53.5)        # xArm 5/6: shoulder -> elbow is 53.5 mm out, 284.5 mm up
_A2 = math.hypot(284.5, 53.5)
_T4X5 = -math.atan(342.5 / 77.5)      # xArm 5: elbow -> wrist folded into one link
_A3X5 = math.hypot(77.5, 342.5)
_D = math.radians

#: UFACTORY's standard D-H tables ("Kinematic and Dynamic Parameters" of each arm), one row per joint:
#: (theta offset rad, d mm, alpha rad, a mm); theta = joint + offset.
STANDARD_DH = {
    "xarm5": [(0, 267, -pi / 2, 0), (_T2, 0, 0, _A2), (-_T2 - _T4X5, 0, 0, _A3X5), (_T4X5, 0, -pi / 2, 76),
              (0, 97, 0, 0)],
    "xarm6": [(0, 267, -pi / 2, 0), (_T2, 0, 0, _A2), (-_T2, 0, -pi / 2, 77.5), (0, 342.5, pi / 2, 0),
              (0, 0, -pi / 2, 76), (0, 97, 0, 0)],
    "xarm7": [(0, 267, -pi / 2, 0), (0, 0, pi / 2, 0), (0, 293, pi / 2, 52.5), (0, 0, pi / 2, 77.5),
              (0, 342.5, pi / 2, 0), (0, 0, -pi / 2, 76), (0, 97, 0, 0)],
    "xarm850": [(0, 364, _D(90), 0), (_D(90), 0, _D(180), 390), (_D(90), 0, _D(-90), 150), (0, 426, _D(-90), 0),
                (0, 0, _D(90), 0), (0, 90, 0, 0)],
    "lite6": [(0, 243.3, _D(-90), 0), (_D(-90), 0, _D(180), 200), (_D(-90), 0, _D(90), 87), (0, 227.6, _D(90), 0),
              (0, 0, _D(-90), 0), (0, 61.5, 0, 0)],
}

#: The flange at zero joints, as the controllers report it: [x, y, z] mm; the tool z points down.
ZERO_TCP_MM = {"xarm5": (207, 0, 112), "xarm6": (207, 0, 112), "xarm7": (206, 0, 120.5),
               "xarm850": (150, 0, 238), "lite6": (87, 0, 154.2)}
DOWN = np.diag([1.0, -1.0, -1.0])  # roll 180 deg, pitch 0, yaw 0

MODELS = sorted(ARMS)


def dh_fk(name: str, q) -> np.ndarray:
    """4x4 flange pose (m) from the standard D-H table."""
    t = np.eye(4)
    for (off, d, alpha, a), qi in zip(STANDARD_DH[name], q, strict=True):
        th = qi + off
        ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(alpha), math.sin(alpha)
        t = t @ np.array([[ct, -st * ca, st * sa, a / 1000 * ct], [st, ct * ca, -ct * sa, a / 1000 * st],
                          [0, sa, ca, d / 1000], [0, 0, 0, 1]])
    return t


class Mj:
    def __init__(self, name: str):
        self.model = mujoco.MjModel.from_xml_path(str(get_arm(name).mjcf_path))
        self.data = mujoco.MjData(self.model)

    def tcp(self, q) -> tuple[np.ndarray, np.ndarray]:
        self.data.qpos[:] = q
        mujoco.mj_kinematics(self.model, self.data)
        site = self.data.site("tcp")
        return site.xpos.copy(), site.xmat.reshape(3, 3).copy()


def samples(name: str, n: int = 12) -> list[np.ndarray]:
    arm = get_arm(name)
    lo, hi = np.array(arm.limits).T
    rng = np.random.default_rng(7)
    rand = rng.uniform(np.maximum(lo, -pi), np.minimum(hi, pi), (n, arm.axis))
    return [np.zeros(arm.axis), np.array(arm.home), *rand]


@pytest.mark.parametrize("name", MODELS)
def test_model_loads_with_the_controllers_joints_and_limits(name):
    arm, m = get_arm(name), Mj(name).model
    names = [m.joint(i).name for i in range(m.njnt)]
    assert names == arm.joint_names == [f"joint{i}" for i in range(1, arm.axis + 1)]
    assert m.nq == m.nv == arm.axis  # arm only: no gripper, no free joints
    assert np.allclose(m.jnt_range, np.array(arm.limits), atol=1e-5)
    assert all(m.jnt_limited)
    assert m.site("tcp").id >= 0
    assert model_of(arm.axis, arm.device_type) is arm


@pytest.mark.parametrize("name", MODELS)
def test_tcp_follows_ufactorys_dh_forward_kinematics(name):
    mj = Mj(name)
    for q in samples(name):
        pos, rot = mj.tcp(q)
        t = dh_fk(name, q)
        assert np.abs(pos - t[:3, 3]).max() < 1e-9, (q, pos, t[:3, 3])
        assert np.abs(rot - t[:3, :3]).max() < 1e-9, q


@pytest.mark.parametrize("name", MODELS)
def test_zero_joints_put_the_flange_where_the_controller_reports_it(name):
    pos, rot = Mj(name).tcp(np.zeros(get_arm(name).axis))
    assert np.allclose(pos * 1000, ZERO_TCP_MM[name], atol=1e-6)
    assert np.allclose(rot, DOWN, atol=1e-9)  # TCP rpy [180, 0, 0] deg


@pytest.mark.parametrize("name", MODELS)
def test_home_points_the_tool_down_in_front_of_the_base_inside_the_limits(name):
    arm = get_arm(name)
    pos, rot = Mj(name).tcp(arm.home)
    assert np.arccos(np.clip(-rot[2, 2], -1, 1)) < 1e-3  # tool z straight down
    assert np.allclose(rot, DOWN, atol=1e-3)               # and no yaw: the zero pose's orientation
    reach = 0.25 if name == "lite6" else 0.3
    assert abs(pos[0] - reach) < 0.01 and abs(pos[1]) < 1e-6 and 0.2 <= pos[2] <= 0.3, pos
    lo, hi = np.array(arm.limits).T
    assert np.min(np.minimum(np.array(arm.home) - lo, hi - np.array(arm.home))) > 0.3  # well inside


@pytest.mark.parametrize("name", MODELS)
def test_description_drives_rios_kinematics(name):
    pytest.importorskip("mink")
    from rio.control import pose_error
    from rio.kinematics import solver_from_description

    arm, mj = get_arm(name), Mj(name)
    desc = description(name)
    assert desc["format"] == "mjcf" and desc["frame"] == "tcp" and desc["frame_type"] == "site"
    assert desc["joints"] == arm.joint_names and desc["home"] == list(arm.home)
    ik = solver_from_description(desc)
    assert ik.joint_names == arm.joint_names
    for q in samples(name, 4):
        pose = ik.fk(q)  # [x, y, z, qw, qx, qy, qz]
        pos, rot = mj.tcp(q)
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, rot.ravel())
        assert np.allclose(pose[:3], pos, atol=1e-9)
        assert min(np.abs(pose[3:] - quat).max(), np.abs(pose[3:] + quat).max()) < 1e-9

    # a pose near home (reachable by construction, also for the 5-joint xArm 5), solved from home
    home = np.array(arm.home)
    q_goal = home + np.random.default_rng(3).uniform(-0.15, 0.15, arm.axis)
    target = ik.fk(q_goal)
    res = ik.solve(target, home, max_iters=200)
    pe, re = pose_error(ik.fk(res.q), target)
    assert res.success and pe < 1e-3 and re < np.deg2rad(1.0), (res, pe, re)
