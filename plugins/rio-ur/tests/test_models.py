"""The MJCF written from each DH table agrees with the DH forward kinematics and with UR's published
zero pose; each home pose is tool-down in front of the base, inside the limits."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from rio_ur.kinematics import flange_pose
from rio_ur.mjcf import arm_mjcf
from rio_ur.models import ARMS


@pytest.mark.parametrize("name", list(ARMS))
def test_mjcf_matches_dh_and_the_published_zero_pose(name):
    m = ARMS[name]
    model = mujoco.MjModel.from_xml_string(arm_mjcf(m))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(1)
    for q in [np.zeros(6), *rng.uniform(-3, 3, (5, 6))]:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        ref = flange_pose(m, q)
        np.testing.assert_allclose(data.site("tcp").xpos, ref[:3], atol=1e-9)
        rot = data.site("tcp").xmat.reshape(3, 3)
        from rio.control import quat_to_matrix

        np.testing.assert_allclose(rot, quat_to_matrix(ref[3:]), atol=1e-9)
    zero = flange_pose(m, np.zeros(6))  # UR: x = a2 + a3, y = -(d4 + d6), z = d1 - d5
    np.testing.assert_allclose(zero[:3], [m.a2 + m.a3, -(m.d[3] + m.d[5]), m.d[0] - m.d[4]], atol=1e-12)


@pytest.mark.parametrize("name", list(ARMS))
def test_home_is_tool_down_in_front_inside_the_limits(name):
    m = ARMS[name]
    p = flange_pose(m, m.home)
    assert 0.25 < p[0] < 0.45 and abs(p[1]) < 0.01 and 0.25 < p[2] < 0.5
    assert abs(abs(p[4]) - 1.0) < 1e-3  # z axis down: 180 deg about x
    lim = np.array(m.limits)
    assert np.all(np.array(m.home) > lim[:, 0] + 0.5) and np.all(np.array(m.home) < lim[:, 1] - 0.5)
