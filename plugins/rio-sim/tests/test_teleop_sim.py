"""The teleop workflow on the packaged sim stations, end to end: the scripted device drives the
real loop (`run_teleop`), the arms move through physics, the grippers grasp, and the world's ground
truth says where things ended up. One script, unchanged, for every station (their tasks taken out: the
script picks where the scene puts the cube, not where a task's episode draws it)."""

from __future__ import annotations

import numpy as np
import pytest
from rio_sim.robots import get_robot
from rio_sim.scenes import CUBE, PICK_OFFSET, PLACE_OFFSET, get_scene
from rio_sim.testing import without_task

from rio.workflows.teleop import run_teleop

# The same script for every station (faster than the default, to keep the suite short).
SCRIPT = {"script": "pick_place", "speed": 0.15, "grasp_s": 0.6}


class Recorder:
    """Keeps, for the last tick of every script phase, each arm's measured tool position and target,
    plus the highest z of every object."""

    def __init__(self) -> None:
        self.phase_end: dict[int, dict] = {}
        self.max_z: dict[str, float] = {}
        self.offsets: dict[int, np.ndarray] = {}

    def __call__(self, tick) -> None:
        dev = tick.info["devices"]["teleop"]
        phase = int(dev["phase"])
        self.offsets[phase] = np.asarray(dev["offset"]).copy()
        self.phase_end[phase] = {b.role: (np.asarray(b.client.get_state()["eef_pose"]).copy(), b.target.copy(),
                                          b.start_pose.copy()) for b in tick.info["arms"]}
        world = tick.env.sensors["world"]
        for name, pose in zip(world.object_names(), world.get_state()["object_poses"], strict=False):
            self.max_z[name] = max(self.max_z.get(name, -1.0), float(pose[2]))


def _run(station: str, middleware: str = "thread"):
    rec = Recorder()
    summary = run_teleop(without_task(station), "scripted", device_config=SCRIPT, middleware=middleware, on_tick=rec,
                         log=None)
    return summary, rec


def _world_cube_and_pad(station_scene: str, arm: str):
    scene = get_scene(station_scene)
    mount = scene.arm(arm)
    home = np.asarray(get_robot(mount.robot).home_tool)
    return mount.to_world(home + PICK_OFFSET), mount.to_world(home + PLACE_OFFSET)


def _check_pick_place(summary, rec, scene: str, arms: dict[str, str]) -> None:
    assert summary.reason == "the device finished", summary.format()
    objects = {o.name: o for o in summary.objects}
    for role, arm in arms.items():
        tag = "" if arm == "arm" else f"_{arm}"
        cube = objects[f"cube{tag}"]
        start_xy, pad = _world_cube_and_pad(scene, arm)
        assert np.allclose(cube.start[:2], start_xy[:2], atol=1e-3)
        # lifted well off the table while carried ...
        assert rec.max_z[f"cube{tag}"] > CUBE / 2 + 0.05, (role, rec.max_z)
        # ... and put down on the pad, resting on the table
        assert np.linalg.norm(cube.end[:2] - pad[:2]) < 0.015, (role, cube.end, pad)
        assert abs(cube.end[2] - CUBE / 2) < 0.004, (role, cube.end)
        # the arm came back to where it started
        report = next(a for a in summary.arms if a.role == role)
        assert np.linalg.norm(report.end[:3] - report.start[:3]) < 0.006, report


@pytest.mark.slow
def test_scripted_teleop_moves_the_arm_to_its_targets_and_picks_the_cube():
    summary, rec = _run("sim-so100")
    # At the end of every move the measured tool is where the script put it (start + planned offset).
    for phase in sorted(p for p in rec.phase_end if 0 <= p < max(rec.phase_end)):
        tool, target, start = rec.phase_end[phase]["arm"]
        planned = start[:3] + rec.offsets.get(phase + 1, rec.offsets[phase])
        assert np.linalg.norm(target[:3] - planned) < 0.004, (phase, target[:3], planned)
        assert np.linalg.norm(tool[:3] - planned) < 0.012, (phase, tool[:3], planned)
    _check_pick_place(summary, rec, "so100", {"arm": "arm"})


@pytest.mark.slow
def test_same_script_on_bimanual():
    summary, rec = _run("sim-bimanual")
    _check_pick_place(summary, rec, "so100_bimanual", {"arm": "left", "arm2": "right"})


@pytest.mark.slow
def test_same_script_on_xarm7_with_eef_actions():
    summary, rec = _run("sim-xarm7")
    _check_pick_place(summary, rec, "xarm7", {"arm": "arm"})


@pytest.mark.slow
@pytest.mark.parametrize("station", ["sim-so100"])
def test_scripted_teleop_over_shared_memory_processes(station):
    """The default middleware: world, arm, gripper, cameras and device each in their own process."""
    summary, rec = _run(station, middleware="shm")
    _check_pick_place(summary, rec, "so100", {"arm": "arm"})
