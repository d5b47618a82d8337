"""The sim drivers behind the standard interfaces, on a small station (thread middleware, tiny
cameras): arm joint and end-effector control, the gripper, cameras that render the shared world,
the world's ground truth, and what happens without OpenGL."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest
from rio_sim.gl import GL_PACKAGES, OFFSCREEN_GL
from rio_sim.robots import get_robot

from rio.control import pose_error
from rio.errors import RioError
from rio.kinematics import solver_from_description
from rio.machine.hide_libraries import C_COMPILER, hide_libraries_env
from rio.runtime.manager import ServerManager
from rio.station import make_station
from rio.testing import skip_tests_without, wait_until

STATION = """
name = "{name}"
rate_hz = 30
[middleware]
name = "{mw}"
[components.world_sensor]
driver = "sim.world"
scene = "so100"
world = "{name}"
[components.arm]
driver = "sim.arm"
world = "{name}"
[components.gripper]
driver = "sim.gripper"
world = "{name}"
[components.wrist_camera]
driver = "sim.camera"
camera = "arm/wrist"
world = "{name}"
width = 96
height = 72
[components.front_camera]
driver = "sim.camera"
camera = "front"
world = "{name}"
width = 96
height = 72
depth = true
{extra}
"""


def station_file(tmp_path, name="drv", mw="thread", extra="") -> str:
    p = tmp_path / f"{name}.toml"
    p.write_text(STATION.format(name=name, mw=mw, extra=extra))
    return str(p)



@pytest.fixture(scope="module")
def station(tmp_path_factory):
    servers, clients, env = make_station(station_file(tmp_path_factory.mktemp("st")))
    with ServerManager(servers), clients["arm"]() as arm, clients["gripper"]() as grip, \
            clients["wrist_camera"]() as wrist, clients["front_camera"]() as front, \
            clients["world_sensor"]() as world:
        yield {"arm": arm, "gripper": grip, "wrist": wrist, "front": front, "world": world}


def test_arm_reaches_joint_targets_at_their_time(station):
    arm = station["arm"]
    home = np.asarray(get_robot("so100").home)
    target = home + np.array([0.3, -0.2, 0.2, 0.1, -0.4])
    t_target = time.monotonic() + 1.0
    arm.move_joints(target, t_target)
    time.sleep(0.5)  # half way there (interpolated), not already arrived
    mid = arm.get_state()["joint_pos"]
    assert 0.2 < np.abs(mid - home).max() / 0.4 < 0.9
    assert wait_until(lambda: np.abs(arm.get_state()["joint_pos"] - target).max() < 0.01, 3.0)
    arm.move_joints(home, time.monotonic() + 0.8)
    assert wait_until(lambda: np.abs(arm.get_state()["joint_pos"] - home).max() < 0.01, 3.0)


def test_arm_reaches_end_effector_targets_and_reports_fk(station):
    arm = station["arm"]
    s = arm.get_state()
    ik = solver_from_description(arm.robot_description())
    assert sum(pose_error(ik.fk(s["joint_pos"]), s["eef_pose"])) < 1e-6  # published eef = FK of joints
    target = s["eef_pose"].copy()
    target[:3] += [0.03, -0.04, -0.03]
    arm.move_eef(target, time.monotonic() + 1.0)
    assert wait_until(lambda: pose_error(arm.get_state()["eef_pose"], target)[0] < 0.002, 4.0)
    pe, re = pose_error(arm.get_state()["eef_pose"], target)
    assert pe < 0.002 and np.rad2deg(re) < 1.0
    arm.home(0.8)
    assert wait_until(lambda: np.abs(arm.get_state()["joint_pos"] - get_robot("so100").home).max() < 0.01, 3.0)


def test_gripper_closes_and_opens(station):
    g = station["gripper"]
    assert g.max_width() == pytest.approx(0.06)
    g.move(0.0, time.monotonic() + 0.3)
    assert wait_until(lambda: g.get_state()["width"] < 0.002, 3.0)
    g.move(0.06, time.monotonic() + 0.3)
    assert wait_until(lambda: g.get_state()["width"] > 0.058, 3.0)


def test_cameras_render_the_shared_world(station):
    skip_tests_without(OFFSCREEN_GL)
    wrist, front, arm = station["wrist"], station["front"], station["arm"]
    s = wrist.get_state()
    assert s["rgb"].shape == (72, 96, 3) and s["rgb"].dtype == np.uint8 and bool(s["rendered"])
    assert s["rgb"].std() > 10  # a real picture, not a flat frame
    assert s["intrinsics"][0, 0] > 0 and s["intrinsics"][0, 2] == 48
    f = front.get_state()
    valid = f["depth"][f["depth"] > 0] * f["depth_scale"]
    assert f["depth"].dtype == np.uint16 and 0.3 < np.median(valid) < 1.5  # the table, ~0.4-0.9 m away
    before = wrist.get_state()["rgb"].astype(float)
    q = arm.get_state()["joint_pos"]
    arm.move_joints(q + np.array([0.6, 0, 0, 0, 0]), time.monotonic() + 0.5)  # pan: the wrist view swings
    assert wait_until(lambda: np.abs(wrist.get_state()["rgb"].astype(float) - before).mean() > 8, 3.0)
    arm.move_joints(q, time.monotonic() + 0.5)
    assert wait_until(lambda: np.abs(arm.get_state()["joint_pos"] - q).max() < 0.01, 3.0)


def test_world_reports_objects_and_can_move_them(station):
    w = station["world"]
    names = w.object_names()
    assert names[0] == "cube" and "can" in names
    s = w.get_state()
    assert s["object_poses"].shape == (len(names), 7) and s["sim_time"] > 0
    assert abs(s["object_poses"][0][2] - 0.0125) < 1e-3  # resting on the table
    w.set_object_pose("cube", [0.25, 0.1, 0.2, 1, 0, 0, 0])

    def landed() -> bool:  # moved there, fell, and rests on the table again
        p = w.get_state()["object_poses"][0]
        return np.allclose(p[:2], [0.25, 0.1], atol=0.01) and abs(p[2] - 0.0125) < 1e-3

    assert wait_until(landed, 3.0)
    w.reset()
    assert wait_until(lambda: np.allclose(w.get_state()["object_poses"][0][:3], [0.2, 0.06, 0.0125], atol=1e-3), 5.0)


def test_gl_problem_is_detected_and_explained():
    code = "from rio_sim.gl import gl_problem; print(gl_problem())"
    env = {**os.environ, "MUJOCO_GL": "osmesa"}  # no OSMesa here: a backend that cannot start
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert "no OpenGL" in out.stdout and "MUJOCO_GL=osmesa" in out.stdout and "apt-get install" in out.stdout


_BARE = """
import os
import rio_sim  # picks the backend
import mujoco  # with MUJOCO_GL=egl and no libEGL, this raised (PyOpenGL's EGL platform finds no library)
from rio_sim.gl import gl_problem
print(os.environ.get("MUJOCO_GL"))
print(gl_problem())
"""


def test_without_libegl_mujoco_imports_and_rendering_says_what_to_install(tmp_path):
    """A bare Debian has no libEGL (package libegl1): rio-sim leaves MuJoCo's default backend there, so the
    physics runs, and the probe notices that GLFW without a display made no context (it only warns)."""
    if not sys.platform.startswith("linux"):
        pytest.skip("rio-sim picks EGL on Linux only")
    skip_tests_without(C_COMPILER)
    env = hide_libraries_env(["libEGL.so.1"], tmp_path, env={k: v for k, v in os.environ.items() if k != "MUJOCO_GL"})
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    out = subprocess.run([sys.executable, "-c", _BARE], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-3000:]
    backend, problem = out.stdout.splitlines()[-2:]
    assert backend == "None", out.stdout
    assert problem.startswith("no OpenGL for offscreen rendering (MUJOCO_GL=default: ") and GL_PACKAGES in problem


def test_cameras_without_gl_publish_placeholders_or_refuse(tmp_path, monkeypatch):
    import rio_sim.gl as gl

    monkeypatch.setattr(gl, "_PROBLEM", "no OpenGL for offscreen rendering (test)")
    servers, clients, _ = make_station(station_file(tmp_path, "nogl"))
    with ServerManager(servers), clients["front_camera"]() as cam:
        s = cam.get_state()
        assert not s["rendered"] and np.all(s["rgb"] == 128) and np.all(s["depth"] == 0)
    extra = "[components.third_camera]\ndriver = \"sim.camera\"\nworld = \"nogl2\"\nrequire_gl = true\n"
    servers, clients, _ = make_station(station_file(tmp_path, "nogl2", extra=extra))
    with pytest.raises(RioError, match="no OpenGL"):
        with ServerManager(servers):
            pass


def test_sim_nodes_without_a_world_fail_with_a_clear_message(tmp_path, monkeypatch):
    import rio_sim.attached as attached

    monkeypatch.setattr(attached, "ATTACH_TIMEOUT_S", 0.5)
    p = tmp_path / "noworld.toml"
    p.write_text('name = "noworld"\n[middleware]\nname = "thread"\n[components.arm]\ndriver = "sim.arm"\n')
    servers, _, _ = make_station(str(p))
    with pytest.raises(RioError, match="sim.world"):
        with ServerManager(servers):
            pass


_MUJOCO_FIRST = """
import os
os.environ.pop("MUJOCO_GL", None)
import mujoco  # imported before rio_sim: MuJoCo settles on GLFW, which has no display here
from rio.runtime.manager import ServerManager
from rio.station import make_station
servers, clients, _ = make_station("sim-so100", middleware="thread")
with ServerManager(servers), clients["front_camera"]() as a, clients["wrist_camera"]() as b:
    print(bool(a.get_state()["rendered"]), bool(b.get_state()["rendered"]), a.get_state()["rgb"].std() > 10)
"""


def test_cameras_render_headless_even_if_mujoco_was_imported_first():
    """Regression: two cameras opening at once on the wrong backend hung the process."""
    skip_tests_without(OFFSCREEN_GL)
    out = subprocess.run([sys.executable, "-c", _MUJOCO_FIRST], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["True", "True", "True"]
