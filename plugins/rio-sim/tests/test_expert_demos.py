"""`rio_sim.expert_demos`: the expert's fast rollouts written as a dataset shaped like a live recording of
`rio teleop sim-so100 --teleop expert --record`: the station's observation and action layout, the environment
state named, each row's action the command decided on the row before (the loop's pairing), the task's verdict
in the episode's metadata; and the stations it refuses."""

from __future__ import annotations

import numpy as np
import pytest
from rio_sim.expert_demos import record_expert_demos
from rio_sim.scenes import get_scene
from rio_sim.task import episode_seed, sample_start

from rio.recording import Dataset
from rio.station.edit import without_role
from rio.station.load import load_station


def test_demonstrations_are_recorded_as_the_loop_records_them(tmp_path):
    rollouts = record_expert_demos(tmp_path / "demos", "sim-so100", episodes=[3, 4], seed=7)
    assert all(r.success for r in rollouts)
    ds = Dataset(tmp_path / "demos")
    assert len(ds) == 2
    task = load_station("sim-so100").components["world_sensor"].config.task
    for ep, k, r in zip(ds, (3, 4), rollouts, strict=True):
        meta = ep.meta
        assert meta["station"] == "sim-so100" and meta["embodiment"] == "single_arm" and ep.fps == 30.0
        assert meta["action_names"] == [f"joint_pos.{i}" for i in range(5)] + ["gripper"]
        assert meta["observation_class"] == "rio.schema:SingleArmObs" and not ep.cameras
        names = meta["environment_state"]["meta.sensors.world.object_poses"]
        assert names[:7] == ["cube.x", "cube.y", "cube.z", "cube.qw", "cube.qx", "cube.qy", "cube.qz"]
        t = meta["metadata"]["task"]
        assert (t["seed"], t["episode"], t["episode_seed"], t["success"]) == (7, k, episode_seed(7, k), True)
        # the start drawn for (7, k), and the rows a control period apart in simulated time
        first = ep.column("meta.sensors.world.object_poses")[0]
        np.testing.assert_allclose(first[0], sample_start(task, get_scene("so100"), 7, k).poses["cube"], atol=1e-9)
        t = ep.column("t") - ep.column("t")[0]
        assert np.abs(t - np.arange(len(t)) / 30).max() <= 0.001 + 1e-9  # each the physics step nearest its tick
        # row t + 1 holds the command decided on row t's observation; row 0 the station's start command
        action, q = ep.column("action"), ep.column("obs.proprio")
        np.testing.assert_array_equal(action[1:], r.commands[:-1])
        np.testing.assert_allclose(action[0], q[0], atol=1e-9)  # home, fingers open: where it starts
        np.testing.assert_allclose(ep.column("obs.proprio_joints"), q[:, :5])
        assert ep.column("meta.sensors.world.success")[-1] and not ep.column("meta.sensors.world.success")[0]


def test_stations_it_cannot_record_are_refused(tmp_path):
    with pytest.raises(ValueError, match="single arm with a gripper"):
        record_expert_demos(tmp_path / "x", "sim-bimanual", episodes=[0])
    with pytest.raises(ValueError, match="single arm with a gripper"):
        record_expert_demos(tmp_path / "x", without_role(load_station("sim-so100"), "gripper"), episodes=[0])
    st = load_station("sim-so100")
    with pytest.raises(ValueError, match="sim.world sensor with a task"):
        record_expert_demos(tmp_path / "x", without_role(st, "world_sensor"), episodes=[0])
