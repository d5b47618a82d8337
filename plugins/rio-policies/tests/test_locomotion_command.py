"""`onnx.locomotion` commanded by a teleop device (`command_from`): the device's twist, read from its ring
(`ObsLayout.inputs`), becomes the observation's command term (scaled, deadband, clipped); and `rio deploy`
hands a station's teleop device to the policy node, so a twist reaches the model on `sim-g1-floating`.

The device is `rio.fake_teleop` (core's test device: a constant twist), served for real over the `thread`
middleware (unit tests) and the station's `shm` (deploy)."""

from __future__ import annotations

import numpy as np
import pytest

from rio.policy import ObsLayout
from rio.schema import HumanoidObs

pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")
from rio_policies.locomotion import G1_DEFAULT_POSE, G1_JOINTS, LocomotionPolicy  # noqa: E402
from rio_policies.testing import G1_STANDING, echo_model, standing_policy  # noqa: E402
from rio_policies.velocity_command import twist_to_command  # noqa: E402

COMMAND = slice(6, 9)  # the command term in unitree_rl_gym's G1 observation
SCALE = np.array([2.0, 2.0, 0.25])  # its command_scale


def obs() -> HumanoidObs:
    q = np.zeros(29)
    return HumanoidObs(proprio=q, joint_pos=q, joint_vel=np.zeros(29), base_quat=np.array([1.0, 0, 0, 0]),
                       base_ang_vel=np.zeros(3))


@pytest.fixture
def device():
    """device(twist) -> the layout of `obs()` with a running fake teleop device 'teleop' among its inputs."""
    from rio.fakes.teleop import FakeTeleop
    from rio.runtime.manager import ServerManager, connect, serve

    open_ = []

    def make(twist):
        manager = ServerManager("thread", [serve(FakeTeleop, name="teleop", twist=list(twist))]).__enter__()
        client = connect(FakeTeleop, "thread", name="teleop")
        open_.extend([client, manager])
        layout = ObsLayout.of(obs())
        layout.inputs = {"teleop": client.ring_ref}
        return layout

    yield make
    for thing in open_:
        thing.__exit__(None, None, None)


def test_twist_to_command_scales_deadbands_and_clips():
    twist = [0.4, -0.02, 9.0, 9.0, 9.0, -3.0]  # linear z and angular x, y are no command
    np.testing.assert_allclose(twist_to_command(twist, [2.0, 1.0, 1.0], [0.05] * 3, [1.0, 0.5, 1.0]),
                               [0.8, 0.0, -1.0])  # vx x2; vy within the deadband; wz clipped to 1
    np.testing.assert_allclose(twist_to_command(twist, [3.0, 10.0, 0.1], [0.0] * 3, [1.0, 0.5, 1.0]),
                               [1.0, -0.2, -0.3])


def test_the_command_term_is_the_devices_scaled_twist(tmp_path, device):
    twist = [0.3, -0.2, 0.0, 0.0, 0.0, 0.6]
    pol = LocomotionPolicy(path=echo_model(tmp_path / "m.onnx", list(range(12))), command=[9.0, 9.0, 9.0],
                           command_from="teleop", twist_gain=[1.0, 2.0, 0.5], command_max=[1.0, 0.3, 1.0], ramp_s=0.0)
    pol.load(device(twist))
    try:
        x = pol.observation(obs())
        np.testing.assert_allclose(x[COMMAND], np.array([0.3, -0.3, 0.3]) * SCALE)  # vy: -0.4 clipped to -0.3
        first = pol(obs(), None, t_obs=1.0).actions[0][:12]  # the echo model hands obs[0:12] back
        default = np.array([G1_DEFAULT_POSE[j] for j in G1_JOINTS[:12]])
        np.testing.assert_allclose((first - default)[COMMAND] / 0.25, np.array([0.3, -0.3, 0.3]) * SCALE, rtol=1e-6)
    finally:
        pol.close()


def test_a_silent_device_commands_standing_still(tmp_path, device):
    pol = LocomotionPolicy(path=echo_model(tmp_path / "m.onnx", list(range(12))), command_from="teleop",
                           command_timeout_s=1e-9, ramp_s=0.0)  # every sample is "too old"
    pol.load(device([0.5, 0.0, 0.0, 0.0, 0.0, 0.0]))
    try:
        np.testing.assert_array_equal(pol.observation(obs())[COMMAND], 0.0)
    finally:
        pol.close()


def test_a_missing_device_is_named(tmp_path):
    pol = LocomotionPolicy(path=echo_model(tmp_path / "m.onnx", list(range(12))), command_from="teleop2")
    with pytest.raises(ValueError, match=r"command_from = 'teleop2'.*\[components.teleop2\]"):
        pol.load(ObsLayout.of(obs()))


@pytest.mark.slow
def test_deploy_on_sim_g1_floating_passes_the_teleop_twist_to_the_model(tmp_path):
    """`rio deploy sim-g1-floating --teleop rio.fake_teleop` (a constant twist, vx > 0): the command term the
    model was given (read back off the echo model's actions) is the device's scaled twist, every step."""
    pytest.importorskip("rio_sim")
    pytest.importorskip("mujoco")
    from rio.workflows.deploy import run_deploy

    gain = 1e-4
    spec, _ = standing_policy(tmp_path, gain, command_from="teleop", twist_gain=[2.0, 1.0, 1.0], ramp_s=0.0)
    chunks: list = []

    def on_tick(tick):
        if tick.info.get("chunk") is not None:
            chunks.append(tick.info["chunk"])
        if len(chunks) >= 40:
            raise KeyboardInterrupt

    summary = run_deploy("sim-g1-floating", spec, duration=120, on_tick=on_tick, log=None,  # rio deploy --teleop
                         device="rio.fake_teleop", device_config={"twist": [0.4, 0.1, 0, 0, 0, 0.5]})
    assert len(chunks) >= 40, summary.format()
    default = np.array([G1_STANDING.get(j, G1_DEFAULT_POSE.get(j, 0.0)) for j in G1_JOINTS[:12]])
    seen = np.array([(c.actions[0][:12] - default)[COMMAND] / (0.25 * gain) for c in chunks])
    want = np.array([0.8, 0.1, 0.5]) * SCALE  # vx 0.4 x 2 (under command_max 1.0), vy 0.1, wz 0.5
    np.testing.assert_allclose(seen, np.tile(want, (len(seen), 1)), atol=0.02)
