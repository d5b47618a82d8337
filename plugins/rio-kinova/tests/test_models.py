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
