"""The packaged stations end to end through the real loop (`run_teleop`, thread middleware): the
fake FR3 traces the scripted square, and on `panda-sim` the fake franky robot drives rio-sim's Panda
through the scripted pick-and-place; the world's ground truth says the cube was carried to the pad."""

from __future__ import annotations

import pytest

from rio.testing import run_scripted_square
from rio.workflows.teleop import run_teleop


def test_fake_station_traces_the_scripted_square():
    run_scripted_square("fr3-fake")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """One scripted pick-and-place recorded by the code of `rio teleop panda-sim --teleop scripted --record`."""
    pytest.importorskip("rio_sim")
    pytest.importorskip("mujoco")
    from rio_sim.testing import record_pick_and_place

    return record_pick_and_place("panda-sim", tmp_path_factory.mktemp("data") / "pick")


@pytest.mark.slow
def test_the_sim_station_records_the_pick_and_place(recorded):
    from rio_sim.testing import check_recorded_pick_and_place

    check_recorded_pick_and_place(recorded, "panda")


@pytest.mark.slow
def test_deploy_replaying_the_episode_does_the_task_again(recorded, tmp_path):
    from rio_sim.testing import check_replay_repeats_the_task

    check_replay_repeats_the_task("panda-sim", recorded, tmp_path / "rollout")


@pytest.mark.slow
def test_sim_station_over_shm_each_node_in_its_own_process():
    """Over shm the arm's and the hand's nodes are separate processes, each with its own fake control
    box on the one simulated robot: neither may hold the other's joints (the box that was sent arm
    motions drives the arm, the one sent hand commands the fingers)."""
    pytest.importorskip("rio_sim")
    pytest.importorskip("mujoco")
    from rio_sim.testing import check_cube_on_pad

    summary = run_teleop("panda-sim", "scripted", device_config={"script": "pick_place", "speed": 0.15,
                                                                 "grasp_s": 1.5}, middleware="shm", log=None)
    check_cube_on_pad(summary, "panda")
