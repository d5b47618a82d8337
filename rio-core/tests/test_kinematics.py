"""rio.kinematics: the shared IK on MuJoCo models (mink) and on URDF (pinocchio).

The test models are generated here from joint tables (origin, rpy, axis, limits), once as MJCF and
once as URDF, so both backends solve the same chains: a 7-DOF arm with the xArm7's public
kinematics and a 5-DOF arm with the SO-100's link lengths.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from rio.kinematics.pin_solver import LIBGOMP
from rio.testing import skip_tests_without

skip_tests_without("mink")  # found, not imported: its import costs every test process 0.5 s
skip_tests_without(LIBGOMP)  # first: without libgomp, importing pinocchio raises ImportError (not a skip)
skip_tests_without("pinocchio")

from rio.control import euler_to_quat, pose_error  # noqa: E402
from rio.kinematics import MinkSolver, PinocchioSolver, solver_from_description  # noqa: E402

H = np.pi / 2
# (xyz, rpy, axis, (lower, upper)) per joint; the tool frame follows the last joint.
ARM7 = [((0, 0, 0.267), (0, 0, 0), (0, 0, 1), (-6.28, 6.28)), ((0, 0, 0), (-H, 0, 0), (0, 0, 1), (-2.059, 2.094)),
        ((0, -0.293, 0), (H, 0, 0), (0, 0, 1), (-6.28, 6.28)), ((0.0525, 0, 0), (H, 0, 0), (0, 0, 1), (-0.19, 3.93)),
        ((0.0775, -0.3425, 0), (H, 0, 0), (0, 0, 1), (-6.28, 6.28)), ((0, 0, 0), (H, 0, 0), (0, 0, 1), (-1.69, 3.14)),
        ((0.076, 0.097, 0), (-H, 0, 0), (0, 0, 1), (-6.28, 6.28))]
TOOL7 = (0, 0, 0.16)
ARM5 = [((0, 0, 0.033), (0, 0, 0), (0, 0, 1), (-2.0, 2.0)), ((0.0306, 0, 0.086), (0, 0, 0), (0, 1, 0), (-1.9, 1.9)),
        ((0.028, 0, 0.11257), (0, 0, 0), (0, 1, 0), (-0.3, 3.0)), ((0, 0, 0.1349), (0, 0, 0), (0, 1, 0), (-1.9, 1.9)),
        ((0, 0, 0.0601), (0, 0, 0), (0, 0, 1), (-3.14, 3.14))]
TOOL5 = (0, 0, 0.05)


def mjcf(chain, tool) -> str:
    body, close = "", ""
    for i, (xyz, rpy, axis, (lo, hi)) in enumerate(chain):
        q = euler_to_quat(*rpy)
        body += (f'<body name="l{i}" pos="{xyz[0]} {xyz[1]} {xyz[2]}" quat="{q[0]} {q[1]} {q[2]} {q[3]}">'
                 f'<joint name="j{i}" axis="{axis[0]} {axis[1]} {axis[2]}" range="{lo} {hi}"/>'
                 f'<geom type="sphere" size="0.02" mass="0.5"/>')
        close += "</body>"
    body += f'<site name="tool" pos="{tool[0]} {tool[1]} {tool[2]}"/>'
    return f'<mujoco><compiler angle="radian"/><worldbody>{body}{close}</worldbody></mujoco>'


def urdf(chain, tool) -> str:
    inertial = ('<inertial><mass value="0.5"/>'
                '<inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>')
    out = ['<robot name="t"><link name="base"/>']
    parent = "base"
    for i, (xyz, rpy, axis, (lo, hi)) in enumerate(chain):
        out.append(f'<link name="l{i}">{inertial}</link><joint name="j{i}" type="revolute"><parent link="{parent}"/>'
                   f'<child link="l{i}"/><origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
                   f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/><limit lower="{lo}" upper="{hi}" effort="1" '
                   'velocity="1"/></joint>')
        parent = f"l{i}"
    out.append(f'<link name="tool"/><joint name="tool_joint" type="fixed"><parent link="{parent}"/>'
               f'<child link="tool"/><origin xyz="{tool[0]} {tool[1]} {tool[2]}" rpy="0 0 0"/></joint></robot>')
    return "".join(out)


def solvers():
    return {
        "mink-7dof": MinkSolver(mjcf(ARM7, TOOL7), "tool", damping=1e-6),
        "pinocchio-7dof": PinocchioSolver(urdf(ARM7, TOOL7), "tool", damping=1e-6),
        "mink-5dof": MinkSolver(mjcf(ARM5, TOOL5), "tool", damping=1e-6),
        "pinocchio-5dof": PinocchioSolver(urdf(ARM5, TOOL5), "tool", damping=1e-6),
    }


@pytest.fixture(scope="module")
def all_solvers():
    return solvers()


def test_mujoco_and_pinocchio_agree_on_forward_kinematics(all_solvers):
    rng = np.random.default_rng(0)
    for dof in ("7dof", "5dof"):
        a, b = all_solvers[f"mink-{dof}"], all_solvers[f"pinocchio-{dof}"]
        for _ in range(50):
            q = a.random_q(rng)
            pe, re = pose_error(a.fk(q), b.fk(q))
            assert pe < 1e-9 and re < 1e-7


@pytest.mark.parametrize("name", ["mink-7dof", "pinocchio-7dof", "mink-5dof", "pinocchio-5dof"])
def test_100_random_reachable_targets_within_1mm_and_1deg(all_solvers, name):
    s = all_solvers[name]
    rng = np.random.default_rng(42)
    seed = 0.5 * (np.clip(s.lower, -np.pi, np.pi) + np.clip(s.upper, -np.pi, np.pi))  # mid-range start
    pos, rot, secs = [], [], []
    t0 = time.perf_counter()
    for _ in range(100):
        target = s.fk(s.random_q(rng))  # reachable by construction
        res = s.solve(target, seed, restarts=40, rng=rng, max_iters=30)
        pe, re = pose_error(s.fk(res.q), target)  # measured independently of the solver's report
        assert res.success and pe <= 1e-3 and np.rad2deg(re) <= 1.0, (name, pe, np.rad2deg(re), res)
        assert np.all(res.q >= s.lower - 1e-9) and np.all(res.q <= s.upper + 1e-9)
        pos.append(pe)
        rot.append(np.rad2deg(re))
        secs.append(res.seconds)
    print(f"\n{name}: 100/100 solved; max error {max(pos) * 1e3:.3f} mm / {max(rot):.3f} deg; "
          f"median {np.median(secs) * 1e3:.1f} ms, max {max(secs) * 1e3:.0f} ms, "
          f"total {time.perf_counter() - t0:.1f} s")


def test_warm_started_small_steps_converge_in_few_iterations(all_solvers):
    """The teleop case: from the current joints to a target a few mm away."""
    s = all_solvers["mink-7dof"]
    q = np.array([0.0, -0.2, 0.0, 0.5, 0.0, 0.7, 0.0])
    for _i in range(20):
        target = s.fk(q)
        target[0] += 0.003
        res = s.solve(target, q, max_iters=10)
        assert res.success and res.iterations <= 4, res
        assert np.abs(res.q - q).max() < 0.05  # no jump to another branch
        q = res.q


def test_unreachable_target_returns_best_effort(all_solvers):
    for name in ("mink-7dof", "pinocchio-7dof"):
        s = all_solvers[name]
        target = np.array([2.0, 0.0, 0.3, 1, 0, 0, 0])  # 2 m away: out of reach
        res = s.solve(target, np.zeros(s.dof), max_iters=30)
        assert not res.success and res.pos_err > 1.0
        assert res.pos_err < 2.0  # it did reach towards it


def test_position_only_solve_on_5dof(all_solvers):
    s = all_solvers["mink-5dof"]
    target = np.array([0.2, 0.05, 0.1, 1, 0, 0, 0])  # orientation unreachable together with the position
    res = s.solve(target, np.array([0, 0.3, 1.5, 1.2, 0]), rot_tol=np.inf, restarts=10, rng=1)
    assert res.success and res.pos_err <= 1e-3


def test_joint_subset_holds_the_other_joints():
    s = MinkSolver(mjcf(ARM7, TOOL7), "tool", joints=["j1", "j3", "j5"])
    assert s.dof == 3
    q_other = np.zeros(7)
    target = s.fk([0.3, 0.6, 0.4])
    res = s.solve(target, np.zeros(3), restarts=10, rng=0)
    assert res.success
    full = MinkSolver(mjcf(ARM7, TOOL7), "tool")
    q_other[[1, 3, 5]] = res.q
    assert sum(pose_error(full.fk(q_other), target)) < 2e-3


def test_solver_from_description_and_bad_inputs():
    s = solver_from_description({"format": "urdf", "xml": urdf(ARM5, TOOL5), "frame": "tool"})
    assert isinstance(s, PinocchioSolver) and s.dof == 5
    s = solver_from_description({"format": "mjcf", "xml": mjcf(ARM5, TOOL5), "frame": "tool", "joints": ["j0", "j1"]})
    assert isinstance(s, MinkSolver) and s.dof == 2
    with pytest.raises(ValueError, match="format"):
        solver_from_description({"format": "sdf", "xml": "", "frame": "x"})
    with pytest.raises(ValueError, match="frame"):
        PinocchioSolver(urdf(ARM5, TOOL5), "no_such_frame")
    with pytest.raises(FileNotFoundError):
        MinkSolver("/nonexistent/arm.xml", "tool")


def test_tool_pose_from_a_controllers_tcp_offset():
    from rio.control import euler_to_quat, rotvec_to_quat
    from rio.kinematics import tool_pose_from_offset

    assert tool_pose_from_offset(None) is None and tool_pose_from_offset([0.0] * 6) is None
    rpy = tool_pose_from_offset([0, 0, 0.1, 0.2, -0.1, 0.3], "rpy")
    np.testing.assert_allclose(rpy, [0, 0, 0.1, *euler_to_quat(0.2, -0.1, 0.3)])
    rv = tool_pose_from_offset([0.01, 0, 0.1, 0.2, -0.1, 0.3], "rotvec")
    np.testing.assert_allclose(rv, [0.01, 0, 0.1, *rotvec_to_quat([0.2, -0.1, 0.3])])
    with pytest.raises(ValueError, match="rotation 'zyx'"):
        tool_pose_from_offset([0, 0, 0.1, 0, 0, 0], "zyx")
