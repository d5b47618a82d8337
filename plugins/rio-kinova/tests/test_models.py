"""The kinematic models: each MJCF (written from Kinova's DH tables) agrees with the DH forward
kinematics, the shipped files are what `rio_kinova.mjcf` writes, and Kinova's Home pose of the Gen3
puts the flange where Kinova's Home tool pose says (less the 2F-85's 0.12 m)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from rio_kinova import dh
from rio_kinova.description import description
from rio_kinova.mjcf import render
from rio_kinova.models import ARMS

from rio.control import euler_to_quat, quat_to_matrix


@pytest.mark.parametrize("name", list(ARMS))
def test_mujoco_fk_equals_the_dh_fk(name):
    arm = ARMS[name]
    model = mujoco.MjModel.from_xml_path(str(arm.mjcf_path))
    data = mujoco.MjData(model)
    site = model.site("tcp").id
    lo = np.array([max(lo, -math.pi) for lo, _ in arm.limits])
    hi = np.array([min(hi, math.pi) for _, hi in arm.limits])
    rng = np.random.default_rng(1)
    for q in [np.zeros(arm.dof), np.array(arm.home), *rng.uniform(lo, hi, (20, arm.dof))]:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        t = dh.fk(arm.dh, q, arm.dh_base)
        np.testing.assert_allclose(data.site_xpos[site], t[:3, 3], atol=1e-9)
        np.testing.assert_allclose(data.site_xmat[site].reshape(3, 3), t[:3, :3], atol=1e-9)
    assert model.nu == arm.dof and [model.joint(i).name for i in range(model.njnt)] == arm.joint_names


@pytest.mark.parametrize("name", list(ARMS))
def test_shipped_mjcf_is_what_the_generator_writes(name):
    assert ARMS[name].mjcf_path.read_text(encoding="utf-8") == render(ARMS[name])


def test_gen3_home_matches_kinovas_home_tool_pose():
    t = dh.fk(dh.GEN3_7DOF, ARMS["gen3"].home, dh.GEN3_7DOF_BASE)
    # Kinova's Home with the 2F-85 configured: tool at about (0.576, 0.001, 0.434) m, pointing forward (+x)
    np.testing.assert_allclose(t[:3, 3] + 0.12 * t[:3, 2], [0.576, 0.001, 0.434], atol=3e-3)
    np.testing.assert_allclose(t[:3, 2], [1.0, 0.0, 0.0], atol=1e-6)


def test_limits_follow_the_user_guides():
    gen3 = ARMS["gen3"]
    assert gen3.continuous == (True, False, True, False, True, False, True)
    np.testing.assert_allclose([math.degrees(gen3.limits[j][1]) for j in (1, 3, 5)], [128.9, 147.8, 120.3])
    assert not any(ARMS["gen3_lite"].continuous)


def test_description_with_a_tool_offset_names_the_tool_site():
    d = description("gen3", tcp_offset=[0, 0, 0.12, 0, 0, 0])
    assert d["frame"] == "tool" and '<site name="tool"' in d["xml"] and d["joints"] == ARMS["gen3"].joint_names


#: Joint origins (xyz m, rpy rad; every joint turns about its z) of Kinova's own URDFs in ros_kortex
#: (kortex_description: gen3_lite/6dof gen3_lite_macro.xacro, gen3/6dof GEN3-6DOF_NO-VISION_URDF_ARM_V01),
#: which take the actuators' angles as they are: an independent check of the DH tables and their offsets.
_URDF = {
    "gen3_lite": ([((0, 0, 0.12825), (0, 0, 0)), ((0, -0.03, 0.115), (1.5708, 0, 0)),
                   ((0, 0.28, 0), (-3.1416, 0, 0)), ((0, -0.14, 0.02), (1.5708, 0, 0)),
                   ((0.0285, 0, 0.105), (0, 1.5708, 0)), ((-0.105, 0, 0.0285), (0, -1.5708, 0))],
                  ((0, 0, 0.13), (0, 0, 0))),  # the DH's end-effector frame is 0.13 m beyond the URDF's
    "gen3_6dof": ([((0, 0, 0.15643), (-3.1416, 0, 0)), ((0, 0.005375, -0.12838), (1.5708, 0, 0)),
                   ((0, -0.41, 0), (3.1416, 0, 0)), ((0, 0.20843, -0.006375), (1.5708, 0, 0)),
                   ((0, -0.00017505, -0.10593), (-1.5708, 0, 0)), ((0, 0.10593, -0.00017505), (1.5708, 0, 0))],
                  ((0, 0, -0.061525), (3.1416, 0, -3.1416))),
}


def _origin(xyz, rpy) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = quat_to_matrix(euler_to_quat(*rpy))  # URDF's rpy: fixed-axis x, then y, then z
    t[:3, 3] = xyz
    return t


def _urdf_fk(name: str, q) -> np.ndarray:
    joints, tip = _URDF[name]
    t = np.eye(4)
    for (xyz, rpy), qi in zip(joints, q, strict=True):
        t = t @ _origin(xyz, rpy) @ _origin((0, 0, 0), (0, 0, qi))
    return t @ _origin(*tip)


@pytest.mark.parametrize("name", list(_URDF))
def test_dh_tables_agree_with_kinovas_urdf(name):
    arm = ARMS[name]
    rng = np.random.default_rng(2)
    for q in [np.zeros(arm.dof), np.array(arm.home), *rng.uniform(-2.0, 2.0, (10, arm.dof))]:
        t, u = dh.fk(arm.dh, q, arm.dh_base), _urdf_fk(name, q)
        np.testing.assert_allclose(t[:3, 3], u[:3, 3], atol=1e-3)  # the URDFs round to 0.1 mm and 1e-4 rad
        np.testing.assert_allclose(t[:3, 2], u[:3, 2], atol=1e-3)
