"""The shipped models and scenes: kinematics match the public data they were written from, homes
are where the scenes (and the teleop script) assume, and every scene compiles with its cameras."""

from __future__ import annotations

import numpy as np
import pytest
from rio_sim.robots import ROBOTS, get_robot
from rio_sim.scenes import PICK_OFFSET, SCENES, build_model, get_scene

from rio.control import euler_to_quat, pose_error, pose_mul
from rio.kinematics import MinkSolver

H = np.pi / 2
# xArm7 joint origins (xyz, rpy) as published in xarm_ros2's URDF; tool 0.16 m along the flange's z
XARM7 = [((0, 0, 0.267), (0, 0, 0)), ((0, 0, 0), (-H, 0, 0)), ((0, -0.293, 0), (H, 0, 0)),
         ((0.0525, 0, 0), (H, 0, 0)), ((0.0775, -0.3425, 0), (H, 0, 0)), ((0, 0, 0), (H, 0, 0)),
         ((0.076, 0.097, 0), (-H, 0, 0))]


def xarm7_fk(q) -> np.ndarray:
    """Forward kinematics from the published joint table, independent of MuJoCo."""
    pose = np.array([0, 0, 0, 1, 0, 0, 0.0])
    for (xyz, rpy), qi in zip(XARM7, q, strict=True):
        pose = pose_mul(pose, np.array([*xyz, *euler_to_quat(*rpy)]))
        pose = pose_mul(pose, np.array([0, 0, 0, *euler_to_quat(0, 0, qi)]))
    return pose_mul(pose, np.array([0, 0, 0.16, 1, 0, 0, 0]))


def solver(name: str) -> MinkSolver:
    r = get_robot(name)
    return MinkSolver(str(r.path), r.tool_site, joints=list(r.arm_joints))


def test_xarm7_model_matches_the_published_kinematics():
    s = solver("xarm7")
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = s.random_q(rng)
        pe, re = pose_error(s.fk(q), xarm7_fk(q))
        assert pe < 1e-4 and re < 1e-4


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_home_puts_the_tool_down_at_home_tool(name):
    r = get_robot(name)
    tool = solver(name).fk(r.home)
    assert np.allclose(tool[:3], r.home_tool, atol=1e-4)
    z_axis = np.array([2 * (tool[4] * tool[6] + tool[3] * tool[5]), 2 * (tool[5] * tool[6] - tool[3] * tool[4]),
                       1 - 2 * (tool[4] ** 2 + tool[5] ** 2)])
    assert z_axis[2] < -0.999  # approach axis points straight down


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_scenes_compile_with_cameras_and_reachable_cubes(scene):
    import mujoco

    sc = get_scene(scene)
    m = build_model(scene)
    cams = [m.camera(i).name for i in range(m.ncam)]
    assert cams == sc.camera_names()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    if sc.base is not None:  # a mobile scene: the arm rides on the base, its cube is a drive away
        site = m.site(f"arm/{get_robot(sc.arms[0].robot).tool_site}").id
        before = d.site_xpos[site].copy()
        d.qpos[[m.joint(f"{sc.base.name}/{j}").qposadr[0] for j in ("x", "y", "yaw")]] = [0.5, -0.2, np.pi / 2]
        mujoco.mj_forward(m, d)
        turned = np.array([[0.0, -1.0], [1.0, 0.0]]) @ before[:2] + [0.5, -0.2]
        assert np.allclose(d.site_xpos[site][:2], turned) and np.isclose(d.site_xpos[site][2], before[2])
        return
    for arm in sc.arms:
        r = get_robot(arm.robot)
        s = solver(arm.robot)
        grasp = np.asarray(r.home_tool) + PICK_OFFSET
        target = np.concatenate([grasp, s.fk(r.home)[3:]])
        assert s.solve(target, np.asarray(r.home)).success  # the cube is within reach, gripper down
        tag = "" if arm.name == "arm" else f"_{arm.name}"
        assert np.allclose(d.body(f"cube{tag}").xpos[:2], arm.to_world(grasp)[:2])


def test_unknown_names_list_what_exists():
    with pytest.raises(KeyError, match="so100"):
        get_robot("ur5")
    with pytest.raises(KeyError, match="xarm7"):
        get_scene("kitchen")
