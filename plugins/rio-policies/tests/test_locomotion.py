"""`onnx.locomotion`: the observation layout of docs/humanoids.md, value by value (small ONNX models built
here with onnx's helper API), and a deploy on `sim-g1-floating`: a model that outputs (next to) zeros holds
the standing pose on the free-floating G1 for 10 s of simulated time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rio.policy import ObsLayout
from rio.schema import HumanoidObs

pytest.importorskip("onnxruntime")
onnx = pytest.importorskip("onnx")
from onnx import TensorProto, helper, numpy_helper  # noqa: E402
from rio_policies.locomotion import G1_DEFAULT_POSE, G1_JOINTS, LocomotionPolicy, projected_gravity  # noqa: E402
from rio_policies.testing import G1_STANDING as STANDING  # noqa: E402
from rio_policies.testing import N_OBS, echo_model, save, standing_policy  # noqa: E402


def quat(axis, angle) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.array([math.cos(angle / 2), *(math.sin(angle / 2) * a)])


def g1_obs(rng, hands: int = 0) -> HumanoidObs:
    q = rng.normal(scale=0.3, size=29)
    return HumanoidObs(proprio=np.concatenate([q, rng.normal(size=hands)]), joint_pos=q,
                       joint_vel=rng.normal(size=29), base_quat=quat([1, 2, 0.5], 0.3),
                       base_ang_vel=rng.normal(size=3))


def test_projected_gravity():
    assert np.allclose(projected_gravity([1, 0, 0, 0]), [0, 0, -1])
    # pitched forward (nose down) by 90 degrees about y: gravity points along the body's +x
    assert np.allclose(projected_gravity(quat([0, 1, 0], math.pi / 2)), [1, 0, 0], atol=1e-12)
    q = quat([0.3, -1, 2], 1.1)  # a rotation matrix' transpose applied to [0, 0, -1]
    w, x, y, z = q
    rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                    [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                    [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    assert np.allclose(projected_gravity(q), rot.T @ [0, 0, -1])


def test_observation_layout_and_actions(tmp_path):
    """Each term where docs/humanoids.md puts it, scaled as documented; actions = default + 0.25 * output on
    the 12 legs, the rest of the body at its default pose (0), the hands where they were."""
    rng = np.random.default_rng(0)
    path = echo_model(tmp_path / "echo.onnx", list(range(12)))  # outputs obs[0:12]
    obs = g1_obs(rng, hands=14)
    pol = LocomotionPolicy(path=path, command=[0.5, -0.2, 0.4], ramp_s=0.0)
    pol.load(ObsLayout.of(obs))
    assert pol.describe() == [("ang_vel", 0, 3), ("gravity", 3, 6), ("command", 6, 9), ("joint_pos", 9, 21),
                              ("joint_vel", 21, 33), ("last_action", 33, 45), ("phase", 45, 47)]
    meta = pol.metadata()
    assert (meta.horizon, meta.action_dim, meta.dt) == (1, 43, pytest.approx(0.02))

    chunk = pol(obs, None, t_obs=5.0)
    x = pol.observation(obs)  # the same observation again (only last_action and nothing else changes)
    legs = np.arange(12)
    default = np.array([G1_DEFAULT_POSE[j] for j in G1_JOINTS[:12]])
    np.testing.assert_allclose(x[0:3], 0.25 * obs.base_ang_vel)
    np.testing.assert_allclose(x[3:6], projected_gravity(obs.base_quat))
    np.testing.assert_allclose(x[6:9], [1.0, -0.4, 0.1])
    np.testing.assert_allclose(x[9:21], obs.joint_pos[legs] - default)
    np.testing.assert_allclose(x[21:33], 0.05 * obs.joint_vel[legs])
    first = chunk.actions[0]
    np.testing.assert_allclose(x[33:45], (first[:12] - default) / 0.25, rtol=1e-6, atol=1e-6)  # the raw output
    ph = 2 * math.pi * (0.02 / 0.8)  # one step after the start
    np.testing.assert_allclose(x[45:47], [math.sin(ph), math.cos(ph)], atol=1e-9)
    # the first output was the first observation's obs[0:12] (float32 through the model)
    first_x = np.concatenate([0.25 * obs.base_ang_vel, projected_gravity(obs.base_quat), [1.0, -0.4, 0.1],
                              (obs.joint_pos[legs] - default)[:3]])
    np.testing.assert_allclose(first[:12], default + 0.25 * first_x, rtol=1e-6, atol=1e-6)
    assert np.all(first[12:29] == 0.0)  # waist and arms: their default pose
    np.testing.assert_allclose(first[29:], obs.proprio[29:])  # the hands hold


def test_config_variants(tmp_path):
    """23 joints and no phase; a model of the wrong size is refused at load, naming the layout."""
    rng = np.random.default_rng(1)
    q = rng.normal(size=23)
    obs = HumanoidObs(proprio=q, joint_pos=q, joint_vel=np.zeros(23), base_quat=np.array([1.0, 0, 0, 0]),
                      base_ang_vel=np.zeros(3))
    terms = ["ang_vel", "gravity", "command", "joint_pos", "joint_vel", "last_action"]
    pol = LocomotionPolicy(path=echo_model(tmp_path / "a.onnx", list(range(12)), 0.0, n_in=45), obs=terms,
                           ramp_s=0.0)
    pol.load(ObsLayout.of(obs))
    a = pol(obs, None, t_obs=0.0).actions[0]
    assert a.shape == (23,) and np.allclose(a[:12], [G1_DEFAULT_POSE[j] for j in G1_JOINTS[:12]])
    with pytest.raises(ValueError, match="takes 47 observation values"):
        LocomotionPolicy(path=echo_model(tmp_path / "b.onnx", list(range(12))), obs=terms).load(ObsLayout.of(obs))


def test_recurrent_state_and_start_ramp(tmp_path):
    """A second input is the model's state, fed back from its second output; after reset the body first
    moves from where it is to the default pose over ramp_s (the model does not run), then the model runs."""
    graph = helper.make_graph(
        [helper.make_node("Add", ["h", "one"], ["h_out"]),
         helper.make_node("Slice", ["h_out", "s0", "s1", "ax"], ["first"]),
         helper.make_node("Tile", ["first", "reps"], ["actions"])], "rnn",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, N_OBS]),
         helper.make_tensor_value_info("h", TensorProto.FLOAT, [1, 4])],
        [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [1, 12]),
         helper.make_tensor_value_info("h_out", TensorProto.FLOAT, [1, 4])],
        [numpy_helper.from_array(np.ones((1, 4), np.float32), "one"),
         numpy_helper.from_array(np.array([0], np.int64), "s0"), numpy_helper.from_array(np.array([1], np.int64), "s1"),
         numpy_helper.from_array(np.array([1], np.int64), "ax"), numpy_helper.from_array(np.array([1, 12], np.int64),
                                                                                          "reps")])
    path = save(graph, tmp_path / "rnn.onnx")
    obs = g1_obs(np.random.default_rng(2))
    pol = LocomotionPolicy(path=path, ramp_s=0.1, action_scale=1.0)
    pol.load(ObsLayout.of(obs))
    default = np.array([G1_DEFAULT_POSE.get(j, 0.0) for j in G1_JOINTS])
    out = [pol(obs, None, t_obs=10.0 + 0.02 * k).actions[0] for k in range(8)]
    for k, want in enumerate([0.2, 0.4, 0.6, 0.8, 1.0]):  # the ramp: 5 steps of 0.1 s at 50 Hz
        np.testing.assert_allclose(out[k], obs.joint_pos + want * (default - obs.joint_pos), atol=1e-9)
    for k, h in ((5, 1.0), (6, 2.0), (7, 3.0)):  # then the model, its state counting up
        np.testing.assert_allclose(out[k][:12], default[:12] + h, rtol=1e-6)
    pol.reset()
    pol.config.ramp_s = 0.0
    np.testing.assert_allclose(pol(obs, None, t_obs=20.0).actions[0][:12], default[:12] + 1.0, rtol=1e-6)


@pytest.mark.slow
def test_deploy_on_the_free_floating_g1_stands_for_10_s(tmp_path):
    """`rio deploy sim-g1-floating --policy <policy.toml>` (its code, the station's shm middleware), a model
    whose output is 1e-4 x obs[0:12] (below 3e-5 rad on any target: it holds the default pose) so the
    observations it was given can be read back off its actions: pelvis above 0.6 m and tilted less than
    20 degrees throughout 10 s of simulated time; upright, the projected gravity is [0, 0, -1]."""
    pytest.importorskip("rio_sim")
    pytest.importorskip("mujoco")
    import mujoco
    from rio_sim.bus import WorldBus
    from rio_sim.scenes import TABLE_HEIGHT, build_model

    from rio.workflows.deploy import run_deploy

    gain = 1e-4
    spec, _ = standing_policy(tmp_path, gain, command=[0.1, -0.05, 0.2])
    model = build_model("g1:floating")
    data = mujoco.MjData(model)
    adr, table = int(model.joint("g1/floating_base_joint").qposadr[0]), model.geom("table").id

    def on_table(qpos) -> int:
        """The G1's geoms touching the table (hands resting on it: leaning, not standing)."""
        data.qpos[:] = qpos
        mujoco.mj_forward(model, data)
        pairs = [(c.geom1, c.geom2) for c in data.contact[:data.ncon]]
        return sum(table in p and model.geom(p[0] if p[1] == table else p[1]).name.startswith("g1/") for p in pairs)

    trace: list[tuple[float, float, float, float]] = []
    chunks: list = []
    bus: list = []

    def on_tick(tick):
        if not bus:
            bus.append(WorldBus.attach("sim", timeout=5))
        s = bus[0].read_state()
        x, y, z, w, qx, qy, qz = s["qpos"][adr:adr + 7]
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (qx * qx + qy * qy)))))
        # simulated time since the episode began (the world stood the G1 up then, however long the station
        # took to come up: on a loaded machine, seconds of physics in which it tipped onto the table)
        t = s["sim_time"] - (trace[0][0] if trace else s["sim_time"])
        touching = on_table(s["qpos"]) if t > 5.0 and len(trace) % 10 == 0 else 0
        trace.append((s["sim_time"], z + TABLE_HEIGHT, tilt, touching))
        if tick.info.get("chunk") is not None:
            chunks.append(tick.info["chunk"])
        if t > 10.0:
            raise KeyboardInterrupt  # the loop's stop: 10 s of simulated time, however fast the machine runs

    try:
        summary = run_deploy("sim-g1-floating", str(spec), duration=60, on_tick=on_tick, log=None)
    finally:
        for b in bus:
            b.close()
    t, h, tilt, touching = np.array(trace).T
    t = t - t[0]
    assert t[-1] > 10.0, summary.format()
    assert summary.details["stats"]["chunks"] > 0.9 * summary.ticks, summary.format()  # the model ran at 50 Hz
    assert h.min() > 0.6 and tilt.max() < 20.0, (h.min(), tilt.max(), summary.format())
    assert touching.sum() == 0 and tilt[t > 5.0].max() < 6.0, (touching.sum(), tilt[t > 5.0].max())  # stood freely
    # what the model saw (after the 2 s ramp): obs[0:12] = gyro (x0.25), gravity, command (x[2, 2, 0.25]), q - q0
    late = [c for c in chunks if c.t_obs > chunks[0].t_obs + 3.0]
    assert len(late) > 100
    default = np.array([STANDING.get(j, G1_DEFAULT_POSE.get(j, 0.0)) for j in G1_JOINTS[:12]])
    seen = np.array([(c.actions[0][:12] - default) / (0.25 * gain) for c in late])
    np.testing.assert_allclose(seen[:, 3:6].mean(axis=0), [0, 0, -1], atol=0.1)
    np.testing.assert_allclose(seen[:, 6:9], np.tile([0.2, -0.1, 0.05], (len(late), 1)), atol=0.02)
