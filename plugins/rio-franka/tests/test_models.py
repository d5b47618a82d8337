"""The arm models: MuJoCo's forward kinematics of the shipped MJCF equals Franka's published DH chain,
the ready pose is where Franka says, and the description's tool offset lands where asked."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rio_franka.description import description
from rio_franka.models import ARMS, DH, FLANGE, HAND_TCP, READY

from rio.control import euler_to_quat, pose_error, pose_mul
from rio.kinematics import solver_from_description


def dh_fk(q) -> np.ndarray:
    """Forward kinematics from the modified DH table (RotX(alpha) TransX(a) RotZ(q) TransZ(d)), no MuJoCo."""
    pose = np.array([0, 0, 0, 1, 0, 0, 0.0])
    for (a, d, alpha), qi in zip((*DH, FLANGE), (*q, 0.0), strict=True):
        pose = pose_mul(pose, np.array([a, 0, 0, *euler_to_quat(alpha, 0, 0)]))
        pose = pose_mul(pose, np.array([0, 0, d, *euler_to_quat(0, 0, qi)]))
    return pose


@pytest.mark.parametrize("name", sorted(ARMS))
def test_mjcf_matches_the_dh_table(name):
    kin = solver_from_description(description(name))
    lo, hi = np.array(ARMS[name].limits).T
    rng = np.random.default_rng(7)
    for _ in range(40):
        q = rng.uniform(lo, hi)
        pe, re = pose_error(kin.fk(q), dh_fk(q))
        assert pe < 1e-6 and re < 1e-6, (q, pe, re)


@pytest.mark.parametrize("name", sorted(ARMS))
def test_ready_pose_is_inside_the_limits_with_the_flange_down_in_front(name):
    arm = ARMS[name]
    lo, hi = np.array(arm.limits).T
    assert np.all(lo < READY) and np.all(np.array(READY) < hi)
    flange = dh_fk(READY)
    np.testing.assert_allclose(flange[:3], [0.3069, 0.0, 0.5903], atol=1e-3)
    assert arm.joint_names == [f"{name}_joint{i}" for i in range(1, 8)]


def test_tool_offset_moves_the_description_frame():
    desc = description("fr3", tcp_offset=HAND_TCP)
    assert desc["frame"] == "tool"
    tool = solver_from_description(desc).fk(READY)
    np.testing.assert_allclose(tool[:3], [0.3069, 0.0, 0.5903 - 0.1034], atol=1e-3)
    assert abs(abs(tool[4]) - 1.0) < 1e-6 or abs(math.hypot(tool[4], tool[5]) - 1.0) < 1e-6  # z still down
