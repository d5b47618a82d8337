"""`rio eval`: seeded trials of a policy on one running sim station (thread middleware, no cameras, short time
limits): each trial from its own drawn start, whatever the trials before it did; ended by the time limit or by
success held; the environment state reaching the policy; a policy that stops ends the evaluation with exit 1;
the result's table and JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("rio_sim")
pytest.importorskip("mujoco")

from rio_sim.scenes import get_scene  # noqa: E402
from rio_sim.task import episode_seed, sample_start  # noqa: E402

from rio.errors import RioError  # noqa: E402
from rio.recording import Dataset  # noqa: E402
from rio.station.load import load_station  # noqa: E402
from rio.workflows.eval import EvalResult, Trial, run_eval  # noqa: E402

STATION = """
name = "{name}"
rate_hz = 30

[middleware]
name = "thread"

[components.world_sensor]
driver = "sim.world"
scene = "so100"
world = "{name}"

[components.world_sensor.task]
seed = 0
time_limit_s = {limit}
min_distance_m = 0

[components.world_sensor.task.start.cube]
x = {cube_x}
y = {cube_y}
yaw = [-3.1416, 3.1416]

[components.world_sensor.task.start.pad]
x = {pad_x}
y = {pad_y}

[components.arm]
driver = "sim.arm"
world = "{name}"

[components.gripper]
driver = "sim.gripper"
world = "{name}"
"""


def station(tmp_path, name: str, limit: float = 1.5, on_pad: bool = False) -> str:
    """A sim-so100-like station; `on_pad`: the cube starts resting on its pad (a success from the start)."""
    ranges = ({"cube_x": [0.2, 0.2], "cube_y": [-0.06, -0.06], "pad_x": [0.2, 0.2], "pad_y": [-0.06, -0.06]}
              if on_pad else {"cube_x": [0.16, 0.24], "cube_y": [0.02, 0.10], "pad_x": [0.16, 0.24],
                              "pad_y": [-0.10, -0.02]})
    path = tmp_path / f"{name}.toml"
    path.write_text(STATION.format(name=name, limit=limit, **ranges))
    return str(path)


def env_echo_model(path) -> str:
    """An ONNX policy over [proprio (6), environment state (28)]: holds the joints and opens the gripper to a
    tenth of cube.x, the environment state's first element (so what it received shows in every action)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    w = np.zeros((34, 6), np.float32)
    for i in range(5):
        w[i, i] = 1.0
    w[6, 5] = 0.1
    graph = helper.make_graph([helper.make_node("MatMul", ["x", "W"], ["y"])], "env_echo",
                              [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 34])],
                              [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, 6])],
                              [numpy_helper.from_array(w, "W")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, str(path))
    return str(path)


def test_trials_start_from_their_own_draws_end_at_the_time_limit_and_the_policy_sees_the_environment(tmp_path):
    pytest.importorskip("onnxruntime")
    st = station(tmp_path, "evtl")
    policy = f"onnx.local,path={env_echo_model(tmp_path / 'echo.onnx')},obs_fields=[\"proprio\",\"environment_state\"]"
    moved = []

    def knock_the_can(tick):  # trial 0 moves an object the task does not place: trial 1 must not see it
        if not moved:
            tick.env.sensors["world"].set_object_pose("can", [0.3, 0.15, 0.03, 1, 0, 0, 0])
            moved.append(tick.t)

    result = run_eval(st, policy, trials=3, seed=5, record=str(tmp_path / "rollouts"), on_tick=knock_the_can,
                      log=None)
    assert result.complete and result.failed is None and result.signal is None
    assert [t.episode for t in result.trials] == [0, 1, 2]
    assert [t.episode_seed for t in result.trials] == [episode_seed(5, k) for k in range(3)]
    assert result.successes == 0 and result.success_rate == 0.0 and result.completion_s() is None
    for t in result.trials:
        assert not t.success and "time limit" in t.ended and t.time_s >= 1.5 and t.seed == 5

    task = load_station(st).components["world_sensor"].config.task
    scene = get_scene("so100")
    ds = Dataset(tmp_path / "rollouts")
    assert len(ds) == 3
    for k, ep in enumerate(ds):
        assert ep.meta["metadata"]["task"]["seed"] == 5 and ep.meta["metadata"]["task"]["episode"] == k
        first = ep.column("meta.sensors.world.object_poses")[0]
        start = sample_start(task, scene, 5, k).poses
        np.testing.assert_allclose(first[0], start["cube"], atol=2e-4)  # drawn there, settled on the table
        np.testing.assert_allclose(first[1], start["pad"], atol=2e-4)
        if k > 0:  # back where the scene puts it, though trial 0 moved it
            np.testing.assert_allclose(first[2][:3], scene.object("can").pos, atol=1e-3)
        # the policy's gripper command is a tenth of the cube's x, which it read from the environment state
        grip = ep.column("action")[5:, 5]
        np.testing.assert_allclose(grip, 0.1 * start["cube"][0], atol=1e-6)
    assert moved


def test_a_trial_ends_once_success_has_held_and_the_command_prints_json(tmp_path, capsys):
    from rio.cli import main

    st = station(tmp_path, "evok", limit=5.0, on_pad=True)
    code = main(["eval", st, "--policy", "rio.policy.testing:SleepPolicyNode,chunk=5,rate_hz=30", "--trials", "2",
                 "--seed", "3", "--hold", "0.3", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["complete"] and out["trials_asked"] == 2
    assert out["successes"] == 2 and out["success_rate"] == 1.0
    for t in out["trials"]:
        assert t["success"] and t["ended"] == "success held 0.3 s"
        assert t["time_s"] < 0.2  # it succeeded from the start: completion is when that began
        assert t["wall_s"] < 3.0  # ended by the success held, long before the 5 s limit
    assert out["completion_s"]["median"] < 0.2


def test_a_policy_that_stops_ends_the_evaluation_with_status_1(tmp_path, capsys):
    from rio.cli import main

    st = station(tmp_path, "evcrash", limit=3.0)
    code = main(["eval", st, "--policy", "rio.policy.testing:CrashPolicyNode,crash_after=2,chunk=5,rate_hz=30",
                 "--trials", "3", "--threshold", "1"])
    text = capsys.readouterr().out
    assert code == 1
    assert "FAILED: the policy stopped" in text and "1 of 3 trials ran" in text


def test_a_station_without_a_task_is_refused(tmp_path):
    text = open(station(tmp_path, "evnotask")).read()
    plain = tmp_path / "notask.toml"  # the same station without its [task] tables
    plain.write_text(text.split("[components.world_sensor.task]")[0] + "[components.arm]"
                     + text.split("[components.arm]")[1])
    with pytest.raises(RioError, match="runs no task"):
        run_eval(str(plain), "rio.policy.testing:SleepPolicyNode", trials=1, log=None)


def test_the_result_reports_rate_times_and_every_trial():
    trials = [Trial(0, 1, 0, 11, True, 4.0, "success held 0.3 s", 4.5),
              Trial(1, 1, 1, 22, False, 10.0, "the task's time limit (10 s) passed", 10.2, ["arm did not follow"]),
              Trial(2, 1, 2, 33, True, 6.0, "success held 0.3 s", 6.4)]
    r = EvalResult("st", "onnx.local", 1, 3, trials, seconds=30.0)
    assert r.successes == 2 and r.success_rate == pytest.approx(2 / 3) and r.complete
    assert r.completion_s() == {"mean": 5.0, "median": 5.0}
    text = r.format()
    assert "2/3 trials succeeded (67%)" in text and "mean 5.00 s, median 5.00 s" in text
    assert "WARNING: trial 1: arm did not follow" in text
    rows = [row for row in (line.split() for line in text.splitlines()) if row[2:3] in (["yes"], ["no"])]
    assert [row[:4] for row in rows] == [["0", "11", "yes", "4.00"], ["1", "22", "no", "10.00"],
                                         ["2", "33", "yes", "6.00"]]
    j = json.loads(json.dumps(r.to_json()))
    assert j["success_rate"] == pytest.approx(2 / 3) and j["trials"][1]["episode_seed"] == 22
    assert EvalResult("st", "p", None, 3, trials[:1], failed="node 'policy' stopped").complete is False
