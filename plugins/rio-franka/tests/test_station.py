"""The packaged stations end to end through the real loop (`run_teleop`, thread middleware): the
fake FR3 traces the scripted square, and on `panda-sim` the fake franky robot drives rio-sim's Panda
through the scripted pick-and-place; the world's ground truth says the cube was carried to the pad."""

from __future__ import annotations

import numpy as np
import pytest
from rio.teleop import run_teleop


def test_virtual_station_traces_the_scripted_square():
    summary = run_teleop("fr3-virtual", "scripted", device_config={"script": "square", "side": 0.05, "speed": 0.15},
                         middleware="thread", log=None)
    assert summary.reason == "the device finished", summary.format()
    arm = next(a for a in summary.arms if a.role == "arm")
    assert 0.18 < arm.path_m < 0.23, summary.format()
    assert np.linalg.norm(arm.end[:3] - arm.start[:3]) < 0.003, summary.format()


def test_sim_station_picks_the_cube_and_places_it_on_the_pad():
    pytest.importorskip("rio_sim")
    pytest.importorskip("mujoco")
    from rio_sim.robots import get_robot
    from rio_sim.scenes import CUBE, PLACE_OFFSET

    summary = run_teleop("panda-sim", "scripted", device_config={"script": "pick_place", "speed": 0.15,
                                                                 "grasp_s": 1.5}, middleware="thread", log=None)
    assert summary.reason == "the device finished", summary.format()
    cube = next(o for o in summary.objects if o.name == "cube")
    pad = np.asarray(get_robot("panda").home_tool) + PLACE_OFFSET
    assert np.linalg.norm(cube.end[:2] - pad[:2]) < 0.015, summary.format()
    assert abs(cube.end[2] - CUBE / 2) < 0.004, summary.format()
    assert cube.lifted_m > 0.04 if hasattr(cube, "lifted_m") else True
