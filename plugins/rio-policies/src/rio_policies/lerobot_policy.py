"""LeRobot policies (ACT, Diffusion; any type LeRobot's factory knows) loaded from a local
`pretrained_model` directory (`config.json`, `model.safetensors` and, when training saved them, the
pre/post-processor pipelines that normalize inputs and unnormalize actions).

Needs `lerobot` (0.4.x), which is not installed with RIO: it brings a multi-GB CUDA torch. Install it
yourself (`pip install torch==2.13.0 lerobot==0.4.4` for a CPU build). Inputs follow LeRobot's
names: `observation.state` from `state` (an observation field or `proprio[a:b]`),
`observation.environment_state` from `environment_state` when the checkpoint was trained on it (its
config names that input: a policy trained on `rio export --format lerobot`'s object poses reads the same
vector here), and `observation.images.<key>` from the camera `images[key]` (default: each camera by its
own name).
"""

from __future__ import annotations

import contextlib
import sys
from typing import Any

import numpy as np
from pydantic import Field

from rio.policy import Policy, PolicyConfig, PolicyMetadata, PolicyNode
from rio.schema import Observation

from .inputs import camera_image, default_images, state_value

#: LeRobot's name of the environment state input (its `OBS_ENV_STATE`), which the LeRobot export writes
ENV_KEY = "observation.environment_state"


class LeRobotPolicy(Policy):
    name = "lerobot.local"
    class Config(PolicyConfig):
        path: str = Field(description="directory with config.json and model.safetensors")
        device: str = Field("cpu", description="torch device: cpu, cuda, cuda:1, mps")
        state: str = Field("proprio", description="observation field (or 'proprio[a:b]') fed as observation.state")
        environment_state: str = Field("environment_state", description="observation field (or 'field[a:b]') fed "
                                       "as observation.environment_state, when the checkpoint takes it")
        images: dict[str, str] | None = Field(None, description="LeRobot image key -> camera (default: camera names)")
        rate_hz: float = Field(30.0, gt=0, description="fps of the training data")

    def setup(self) -> None:
        self.model: Any = None
        self.pre = self.post = None

    def load(self, layout: Any) -> None:
        import torch  # noqa: F401  (fail here, with a clear ImportError, when lerobot's torch is absent)
        from lerobot.configs.policies import PreTrainedConfig
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors

        super().load(layout)
        cfg = PreTrainedConfig.from_pretrained(self.config.path)
        cfg.device = self.config.device
        self.kind = cfg.type
        # LeRobot prints ("Loading weights from local directory"): to stderr, so stdout stays the command's own
        # (`rio eval --json` prints one JSON object there)
        with contextlib.redirect_stdout(sys.stderr):
            self.model = get_policy_class(cfg.type).from_pretrained(self.config.path, config=cfg)
        self.model.eval()
        try:
            self.pre, self.post = make_pre_post_processors(cfg, pretrained_path=self.config.path)
        except (FileNotFoundError, OSError):  # saved without processors: inputs are used as they are
            self.pre = self.post = None
        self.horizon = int(getattr(cfg, "n_action_steps", None) or getattr(cfg, "chunk_size", 1))
        # the environment state is an input only where training gave it one (ACT and Diffusion read it then)
        self.env_input = ENV_KEY in (cfg.input_features or {})

    def metadata(self) -> PolicyMetadata:
        cams = default_images(self.layout.cameras, self.config.images, "{camera}")
        return PolicyMetadata(f"{self.name}:{self.kind}", self.layout.action_dim, self.horizon,
                              1.0 / self.config.rate_hz, cameras=sorted(set(cams.values())))

    def reset(self) -> None:
        if self.model is not None:
            self.model.reset()

    def prepare(self, obs: Observation, instruction: str | None) -> dict[str, Any]:
        import torch

        dev = self.config.device
        batch: dict[str, Any] = {"observation.state": torch.as_tensor(
            state_value(obs, self.config.state), dtype=torch.float32, device=dev)[None]}
        if self.env_input:
            try:
                env = state_value(obs, self.config.environment_state)
            except ValueError as e:  # a station that measures no object poses
                raise ValueError(f"lerobot.local: the checkpoint {self.config.path} takes {ENV_KEY}, but {e} "
                                 "(evaluate it on the station whose world sensor recorded its data)") from None
            batch[ENV_KEY] = torch.as_tensor(env, dtype=torch.float32, device=dev)[None]
        for key, cam in default_images(obs.cameras, self.config.images, "{camera}").items():
            img = torch.as_tensor(np.ascontiguousarray(camera_image(obs, cam)), device=dev)
            batch[f"observation.images.{key}"] = img.permute(2, 0, 1)[None].float() / 255.0
        if instruction is not None:
            batch["task"] = instruction
        return self.pre(batch) if self.pre is not None else batch

    def infer(self, batch: dict[str, Any]) -> np.ndarray:
        import torch

        with torch.inference_mode():
            actions = self.model.predict_action_chunk(self._with_history(batch))
            if self.post is not None:
                actions = self.post(actions)
        return actions[0].detach().to("cpu", torch.float64).numpy()


    def _with_history(self, batch: dict[str, Any]) -> dict[str, Any]:
        """Policies with an observation history (Diffusion: n_obs_steps) read it from their queues,
        which their own `select_action` fills before predicting; do the same here so a chunk can be
        asked for directly (images stacked under "observation.images", as that method does)."""
        queues = getattr(self.model, "_queues", None)
        if queues is None:
            return batch
        import torch
        from lerobot.policies.utils import populate_queues

        batch = {k: v for k, v in batch.items() if k != "action"}  # the preprocessor's empty action slot
        features = list(getattr(self.model.config, "image_features", None) or [])
        if features and "observation.images" in queues:
            batch = {**batch, "observation.images": torch.stack([batch[k] for k in features], dim=-4)}
        self.model._queues = populate_queues(queues, batch)
        return batch


LeRobotConfig = LeRobotPolicy.Config


class LeRobotNode(PolicyNode):
    policy_class = LeRobotPolicy
