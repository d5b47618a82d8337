"""The packaged stations end to end: `ur5e-virtual` traces the scripted square through the real ur-rtde
against the emulator (its own process), and `ur5e-sim` carries the cube to the pad with the scripted
pick-and-place (the emulator's joints and the URCap's fingers are rio-sim's); the world's ground truth
says where the cube went. Plus one `rio ur`
command against an emulator, through the real command line."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from rio.teleop import run_teleop


def rio(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    out = subprocess.run([sys.executable, "-m", "rio", *args], capture_output=True, text=True, timeout=timeout,
                         stdin=subprocess.DEVNULL)
    assert out.returncode == 0, (out.stdout[-3000:], out.stderr[-3000:])
    return out


def test_the_virtual_station_traces_the_scripted_square():
    summary = run_teleop("ur5e-virtual", "scripted", device_config={"script": "square", "side": 0.05, "speed": 0.15},
                         middleware="thread", log=None)
    assert summary.reason == "the device finished", summary.format()
    arm = next(a for a in summary.arms if a.role == "arm")
    assert 0.18 < arm.path_m < 0.23, summary.format()  # four 5 cm edges
    assert np.linalg.norm(arm.end[:3] - arm.start[:3]) < 0.003, summary.format()


def test_rio_ur_status_reads_the_emulated_controller(emulator):
    emulator.inject("protective_stop")
    out = rio("ur", "status", "--ip", emulator.host, timeout=60).stdout
    assert "Robotmode: RUNNING" in out and "PROTECTIVE_STOP" in out and "remote control: true" in out, out
    out = rio("ur", "unlock-protective-stop", "--ip", emulator.host, timeout=60).stdout
    assert "Safetystatus: NORMAL" in out and emulator.state()["safety_mode"] == 1, out


def test_scripted_pick_and_place_on_the_sim_station_carries_the_cube_to_the_pad():
    pytest.importorskip("mujoco")
    pytest.importorskip("rio_sim")
    pytest.importorskip("rio_robotiq")
    summary = run_teleop("ur5e-sim", "scripted", middleware="thread", log=None)  # the emulator: its own process
    assert summary.reason == "the device finished", summary.format()
    cube = next(o for o in summary.objects if o.name == "cube")  # the world's ground truth
    assert np.linalg.norm(cube.end[:2] - cube.start[:2]) > 0.10, summary.format()  # carried to the pad (12 cm) ...
    assert cube.max_z > cube.start[2] + 0.04, summary.format()  # ... lifted on the way ...
    assert abs(cube.end[2] - cube.start[2]) < 0.005, summary.format()  # ... and put down
