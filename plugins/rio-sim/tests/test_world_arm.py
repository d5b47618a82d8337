"""`WorldArm`: an arm of a running sim world for an emulator, in this process or another one."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from rio_sim.robots import get_robot
from rio_sim.testing import running_world
from rio_sim.world_arm import WorldArm, parse_sim_target

from rio import clock
from rio.errors import RioError
from rio.testing import wait_until

# another process (same RIO_SIM_SESSION, inherited) moves joint 1 and reports what it reads back
_OTHER_PROCESS = """
import sys
import numpy as np
from rio import clock
from rio.testing import wait_until
from rio_sim.world_arm import WorldArm
arm = WorldArm.attach(sys.argv[1], "arm", timeout=30)
q = arm.joint_pos()
q[0] += float(sys.argv[2])
arm.command_joints(q, clock.now() + 0.3)
ok = wait_until(lambda: abs(arm.joint_pos()[0] - q[0]) < 0.01, 15.0)
print("reached" if ok else f"stuck at {arm.joint_pos()[0]}", flush=True)
arm.close()
"""


@pytest.fixture(scope="module")
def world():
    with running_world("xarm7", "wa") as w:
        yield w


def test_parse_sim_target():
    assert parse_sim_target("sim") == ("arm", "sim")
    assert parse_sim_target("sim:left") == ("left", "sim")
    assert parse_sim_target("sim:left@w") == ("left", "w")
    assert parse_sim_target("sim:@w") == ("arm", "w")
    for other in ("/dev/ttyACM0", "virtual", "simulator", "192.168.1.10", ""):
        assert parse_sim_target(other) is None


def test_attach_reads_home_and_moves_joints_and_fingers(world):
    robot = get_robot("xarm7")
    with WorldArm.attach("wa", "arm", timeout=30) as arm:
        assert arm.robot.name == "xarm7" and arm.model.nu == arm.bus.nu and arm.scene == "xarm7"
        assert np.allclose(arm.joint_pos(), robot.home, atol=0.02)
        assert arm.finger_width() == pytest.approx(robot.max_width, abs=0.005)  # opened at home

        target = np.asarray(robot.home) + np.array([0.2, -0.1, 0.1, 0.15, -0.1, 0.1, 0.3])
        arm.command_joints(target, clock.now() + 0.5)
        assert wait_until(lambda: np.abs(arm.joint_pos() - target).max() < 0.01, 10.0), arm.joint_pos()

        q2 = target.copy()
        q2[6] -= 0.4
        arm.command_joints([q2[6]], clock.now() + 0.3, joints=[6])  # one joint; the others keep theirs
        assert wait_until(lambda: np.abs(arm.joint_pos() - q2).max() < 0.01, 10.0), arm.joint_pos()

        arm.command_width(0.02, clock.now() + 0.3)
        assert wait_until(lambda: abs(arm.finger_width() - 0.02) < 0.002, 10.0), arm.finger_width()
        arm.command_width(robot.max_width, clock.now() + 0.3)
        assert wait_until(lambda: abs(arm.finger_width() - robot.max_width) < 0.002, 10.0)

        with pytest.raises(ValueError, match="targets"):
            arm.command_joints([0.0, 0.0], clock.now())
        arm.command_joints(robot.home, clock.now() + 0.5)
        assert wait_until(lambda: np.abs(arm.joint_pos() - robot.home).max() < 0.01, 10.0)
        arm.check_alive()
    with pytest.raises(RuntimeError, match="closed"):
        arm.joint_pos()


def test_an_emulator_in_another_process_moves_the_arm(world):
    with WorldArm.attach("wa", "arm", timeout=30) as arm:
        q0 = arm.joint_pos()
        run = subprocess.run([sys.executable, "-c", _OTHER_PROCESS, "wa", "0.25"], capture_output=True,
                             text=True, timeout=120)
        assert run.returncode == 0 and "reached" in run.stdout, run.stdout + run.stderr
        assert arm.joint_pos()[0] == pytest.approx(q0[0] + 0.25, abs=0.01)
        arm.command_joints(q0, clock.now() + 0.5)
        assert wait_until(lambda: np.abs(arm.joint_pos() - q0).max() < 0.01, 10.0)


def test_unknown_arm_or_world_is_refused(world):
    with pytest.raises(KeyError, match="no arm 'left'"):
        WorldArm.attach("wa", "left", timeout=5)
    with pytest.raises(RioError, match="no sim world"):
        WorldArm.attach("no-such-world", timeout=0.1)


def test_arm_sees_its_world_stop():
    with running_world("xarm7", "wa2"):
        arm = WorldArm.attach("wa2", timeout=30)
        arm.check_alive()
    with pytest.raises(RioError, match="stopped"):
        arm.check_alive()
    with pytest.raises(RioError, match="stopped"):
        arm.command_joints(arm.robot.home, clock.now())
    arm.close()
    arm.close()  # idempotent


@pytest.mark.parametrize("scene", ["xarm6", "lite6"])
def test_other_ufactory_class_arms_live_in_their_scenes(scene):
    robot = get_robot(scene)
    with running_world(scene, f"wa-{scene}"), WorldArm.attach(f"wa-{scene}", timeout=30) as arm:
        assert arm.robot is robot and len(arm.joint_pos()) == 6
        assert np.allclose(arm.joint_pos(), robot.home, atol=0.02)
        target = np.asarray(robot.home) + np.array([0.2, 0.1, -0.1, 0.2, -0.15, 0.3])
        arm.command_joints(target, clock.now() + 0.5)
        arm.command_width(0.01, clock.now() + 0.3)
        assert wait_until(lambda: np.abs(arm.joint_pos() - target).max() < 0.01, 10.0), arm.joint_pos()
        assert wait_until(lambda: abs(arm.finger_width() - 0.01) < 0.002, 10.0), arm.finger_width()
