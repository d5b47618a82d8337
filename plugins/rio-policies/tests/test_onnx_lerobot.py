"""ONNX (a small model built here with onnx's helper API) and LeRobot (ACT and Diffusion built from
config with random weights, saved and reloaded; skipped when lerobot is not installed)."""

from __future__ import annotations

import numpy as np
import pytest

from rio.policy import ObsLayout
from rio.schema import Camera, HumanoidObs, SingleArmObs


def linear_model(path, n_in: int, n_out: int, w: np.ndarray, b: np.ndarray) -> None:
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper, numpy_helper

    graph = helper.make_graph(
        [helper.make_node("Gemm", ["obs", "W", "b"], ["y"], transB=1), helper.make_node("Tanh", ["y"], ["action"])],
        "policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, n_in])],
        [helper.make_tensor_value_info("action", TensorProto.FLOAT, [1, n_out])],
        [numpy_helper.from_array(w.astype(np.float32), "W"), numpy_helper.from_array(b.astype(np.float32), "b")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8  # what every onnxruntime since 1.10 reads
    onnx.checker.check_model(model)
    onnx.save(model, str(path))


def test_onnx_rl_policy(tmp_path):
    pytest.importorskip("onnxruntime")
    from rio_policies.onnx_policy import OnnxPolicy

    rng = np.random.default_rng(0)
    n = 4
    w, b = rng.normal(size=(n, 2 * n + n)), rng.normal(size=n)
    linear_model(tmp_path / "walk.onnx", 3 * n, n, w, b)
    obs = HumanoidObs(proprio=rng.normal(size=n), joint_pos=rng.normal(size=n), joint_vel=rng.normal(size=n))
    pol = OnnxPolicy(path=str(tmp_path / "walk.onnx"), obs_fields=["joint_pos", "joint_vel"], last_action=True,
                     scale=0.5, relative=True, rate_hz=50)
    pol.load(ObsLayout.of(obs))
    assert pol.metadata().horizon == 1 and pol.metadata().dt == pytest.approx(0.02)
    c1 = pol(obs, None, t_obs=1.0)
    x = np.concatenate([obs.joint_pos, obs.joint_vel, np.zeros(n)]).astype(np.float32)
    want1 = obs.proprio + 0.5 * np.tanh(w.astype(np.float32) @ x + b.astype(np.float32))
    np.testing.assert_allclose(c1.actions[0], want1, rtol=1e-5, atol=1e-6)
    c2 = pol(obs, None, t_obs=1.02)  # the previous action is now part of the input
    x2 = np.concatenate([obs.joint_pos, obs.joint_vel, want1]).astype(np.float32)
    want2 = obs.proprio + 0.5 * np.tanh(w.astype(np.float32) @ x2 + b.astype(np.float32))
    np.testing.assert_allclose(c2.actions[0], want2, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("kind", ["act", "diffusion"])
def test_lerobot_policy_from_a_saved_directory(tmp_path, kind, capsys):
    pytest.importorskip("lerobot")
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.factory import get_policy_class, make_policy_config, make_pre_post_processors
    from rio_policies.lerobot_policy import LeRobotPolicy

    size = (96, 96) if kind == "diffusion" else (48, 64)
    # no ImageNet backbone: torchvision would download it, and tests build everything offline
    cfg = make_policy_config(kind, device="cpu", pretrained_backbone_weights=None)
    cfg.input_features = {"observation.state": PolicyFeature(FeatureType.STATE, (4,)),
                          "observation.images.front": PolicyFeature(FeatureType.VISUAL, (3, *size))}
    cfg.output_features = {"action": PolicyFeature(FeatureType.ACTION, (4,))}
    policy = get_policy_class(kind)(cfg)  # random weights
    policy.save_pretrained(tmp_path / "model")
    for processor in make_pre_post_processors(cfg, dataset_stats=None):  # as a training run saves them
        processor.save_pretrained(tmp_path / "model")
    obs = SingleArmObs(proprio=np.zeros(4), cameras={"front": Camera(rgb=np.zeros((*size, 3), np.uint8))})
    pol = LeRobotPolicy(path=str(tmp_path / "model"), rate_hz=30)
    capsys.readouterr()
    pol.load(ObsLayout.of(obs))
    assert capsys.readouterr().out == ""  # LeRobot's own prints kept off stdout (`rio eval --json` prints there)
    chunk = pol(obs, None, t_obs=0.0)
    assert chunk.actions.shape[1] == 4 and chunk.horizon >= 1 and np.isfinite(chunk.actions).all()


def test_lerobot_policy_trained_on_the_environment_state_reads_it(tmp_path):
    """A checkpoint whose inputs name observation.environment_state (ACT on state + object poses, as trained on
    `rio export --format lerobot`) is fed the observation's environment_state, through the saved normalizer:
    moving only the cube moves the chunk. One without that input ignores it, and a station that measures no
    object poses is told so, naming the input."""
    pytest.importorskip("lerobot")
    import torch
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.factory import get_policy_class, make_policy_config, make_pre_post_processors
    from rio_policies.lerobot_policy import LeRobotPolicy

    cfg = make_policy_config("act", device="cpu", chunk_size=5, n_action_steps=5, dim_model=32,
                             dim_feedforward=64, n_heads=2, n_encoder_layers=1, use_vae=False)
    cfg.input_features = {"observation.state": PolicyFeature(FeatureType.STATE, (4,)),
                          "observation.environment_state": PolicyFeature(FeatureType.ENV, (3,))}
    cfg.output_features = {"action": PolicyFeature(FeatureType.ACTION, (4,))}
    torch.manual_seed(0)
    policy = get_policy_class("act")(cfg)
    policy.save_pretrained(tmp_path / "model")
    stats = {"observation.state": {"mean": np.zeros(4), "std": np.ones(4)},
             "observation.environment_state": {"mean": np.array([0.2, 0.05, 0.0]), "std": np.full(3, 0.02)},
             "action": {"mean": np.zeros(4), "std": np.ones(4)}}
    for processor in make_pre_post_processors(cfg, dataset_stats=stats):
        processor.save_pretrained(tmp_path / "model")

    def chunk(env):
        obs = SingleArmObs(proprio=np.zeros(4), environment_state=None if env is None else np.asarray(env))
        pol = LeRobotPolicy(path=str(tmp_path / "model"), rate_hz=30)
        pol.load(ObsLayout.of(obs))
        return pol(obs, None, t_obs=0.0).actions

    here, there = chunk([0.2, 0.05, 0.02]), chunk([0.24, 0.09, 0.02])
    assert here.shape == (5, 4) and np.isfinite(here).all()
    assert np.abs(here - there).max() > 1e-3  # the cube's pose reached the model
    np.testing.assert_allclose(chunk([0.2, 0.05, 0.02]), here, atol=1e-6)  # and nothing else changed it
    with pytest.raises(ValueError, match="observation.environment_state"):
        chunk(None)
