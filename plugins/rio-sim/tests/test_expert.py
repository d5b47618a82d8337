"""The scripted expert (`teleop.expert`): its success rate over seeds (fast rollouts, no station), then the
real command recording demonstrations unattended, a replay of one succeeding again from the same start,
and the task's time limit ending runs (the expert saying discard before it)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rio_sim.expert_rollout import expert_rollout
from rio_sim.scenes import get_scene
from rio_sim.task import sample_start
from rio_sim.testing import without_task

from rio.cli import main
from rio.loop.control_loop import SETTLE_MAX_S
from rio.recording import Dataset
from rio.station.edit import with_component
from rio.station.load import load_station


def world_config(station: str):
    return load_station(station).components["world_sensor"].config


@pytest.mark.parametrize(("station", "seeds"), [("sim-so100", 20), ("sim-bimanual", 10)])
def test_the_expert_succeeds_from_every_start(station, seeds):
    """Episodes 0..seeds-1 of seed 0, each from its own drawn start: cube anywhere in its range, at any yaw."""
    cfg = world_config(station)
    results = [expert_rollout(cfg.scene, cfg.task, 0, k) for k in range(seeds)]
    rate = sum(r.success for r in results) / seeds
    print(f"{station}: expert success {rate:.2f} over {seeds} seeds; episode times "
          f"{min(r.time_s for r in results):.1f}-{max(r.time_s for r in results):.1f} s (simulated)")
    assert rate >= 0.9, [(k, r) for k, r in enumerate(results) if not r.success]
    assert all(r.time_s < cfg.task.time_limit_s / 2 for r in results if r.success)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """`rio teleop sim-so100 --teleop expert --record D --episodes 2 --seed 7`, headless (thread middleware)."""
    root = tmp_path_factory.mktemp("expert") / "demos"
    code = main(["teleop", "sim-so100", "--teleop", "expert", "--record", str(root), "--episodes", "2", "--seed", "7",
                 "-m", "thread", "--on-end", "ask"])  # ask: only the device's verdict keeps an episode unattended
    return root, code


def test_the_command_records_successful_demonstrations_from_varied_starts(recorded, capsys):
    root, code = recorded
    assert code == 0
    ds = Dataset(root)
    assert len(ds) == 2
    cfg = world_config("sim-so100")
    scene = get_scene(cfg.scene)
    starts = []
    for k, ep in enumerate(ds):
        task = ep.meta["metadata"]["task"]
        assert task["success"] is True and task["seed"] == 7 and task["episode"] == k
        assert ep.meta["ended_by"] == "keep"
        drawn = sample_start(cfg.task, scene, 7, k).poses
        assert set(task["start"]) == set(drawn)
        for name, pose in drawn.items():
            np.testing.assert_allclose(task["start"][name], pose, atol=1e-6)
        # the recorded ground truth starts there and ends with the cube on the pad
        poses = ep.column("meta.sensors.world.object_poses")
        np.testing.assert_allclose(poses[0, 0, :2], drawn["cube"][:2], atol=2e-3)
        assert np.linalg.norm(poses[-1, 0, :2] - poses[-1, 1, :2]) < 0.03
        assert ep.column("meta.sensors.world.success")[-1]
        names = ep.meta["environment_state"]["meta.sensors.world.object_poses"]
        assert names[:8] == ["cube.x", "cube.y", "cube.z", "cube.qw", "cube.qx", "cube.qy", "cube.qz", "pad.x"]
        starts.append(drawn["cube"])
    assert np.linalg.norm(np.subtract(starts[0][:2], starts[1][:2])) > 1e-3  # two episodes, two starts


def test_a_replay_starts_where_the_episode_started_and_succeeds_again(recorded):
    from rio.workflows.replay import replay_episode

    root, _ = recorded
    recorded_task = Dataset(root).episode(1).meta["metadata"]["task"]
    summary = replay_episode(root, 1, "sim-so100", middleware="thread", approach_s=0.5, log=None)
    assert summary.task["start"] == recorded_task["start"], summary.format()
    assert summary.success is True, summary.format()
    assert summary.to_json()["success"] is True and "task pick_place: SUCCESS" in summary.format()


def _with_time_limit(station, seconds: float):
    st = load_station(station)
    task = st.components["world_sensor"].config.task.model_dump()
    return with_component(st, "world_sensor", fields={"task": {**task, "time_limit_s": seconds}})


def test_the_time_limit_ends_a_run_unsuccessful():
    from rio.workflows.teleop import run_teleop

    summary = run_teleop(_with_time_limit("sim-so100", 1.5), "scripted", middleware="thread", log=None)
    assert summary.reason == "the task's time limit (1.5 s) passed", summary.format()
    # judged after the arm settled (up to SETTLE_MAX_S more), in simulated time
    assert summary.success is False and 1.5 <= summary.task["time_s"] < 1.5 + SETTLE_MAX_S + 1.0
    assert "task pick_place: FAILED after" in summary.format()


def test_the_expert_says_discard_before_the_time_limit():
    from rio.workflows.teleop import run_teleop

    summary = run_teleop(_with_time_limit("sim-so100", 2.5), "expert", middleware="thread", log=None)
    # the device ended it (1 s before the limit, give_up_s), not the loop at the limit
    assert summary.reason == "the device finished" and summary.details["verdict"] == "discard", summary.format()
    assert summary.success is False


def test_without_a_task_nothing_is_judged():
    from rio.workflows.teleop import run_teleop

    summary = run_teleop(without_task("sim-so100"), "scripted", middleware="thread", duration=0.5, log=None)
    assert summary.success is None and summary.task == {}
    assert "task" not in summary.format() and json.loads(json.dumps(summary.to_json()))["success"] is None
