"""ONNX models on onnxruntime: RL controllers (locomotion, trained in simulation) and any exported
policy whose input is a state vector.

The model's input is the concatenation of `obs_fields` (observation fields or `proprio[a:b]`
slices), plus the previous action when `last_action` is set, as float32 [1, N]. Its output
([D], [1, D] or [1, H, D]) becomes a chunk of H actions (H = 1 for an RL controller), mapped to the
station as `offset + scale * output` (plus the current `proprio` when `relative`, as for policies
that output joint offsets from the current pose).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.policy import Policy, PolicyConfig, PolicyMetadata, PolicyNode
from rio.schema import Observation

from .inputs import state_value


class OnnxPolicy(Policy):
    name = "onnx.local"
    class Config(PolicyConfig):
        path: str = Field(description="the .onnx file")
        obs_fields: list[str] = Field(default_factory=lambda: ["proprio"])
        last_action: bool = Field(False, description="append the previous action to the model's input")
        input: str | None = Field(None, description="input name (default: the model's first)")
        output: str | None = Field(None, description="output name (default: the model's first)")
        scale: float | list[float] = 1.0
        offset: float | list[float] = 0.0
        relative: bool = False
        rate_hz: float = Field(50.0, gt=0, description="control rate the model was trained at")
        threads: int = Field(1, ge=1, description="onnxruntime intra-op threads")

    def setup(self) -> None:
        self.session: Any = None
        self.prev: np.ndarray | None = None
        self.current: np.ndarray | None = None

    def load(self, layout: Any) -> None:
        import onnxruntime as ort

        super().load(layout)
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = self.config.threads
        self.session = ort.InferenceSession(self.config.path, opts, providers=["CPUExecutionProvider"])
        self.in_name = self.config.input or self.session.get_inputs()[0].name
        self.out_name = self.config.output or self.session.get_outputs()[0].name
        shape = self.session.get_outputs()[0].shape if self.config.output is None else None
        self.horizon = int(shape[1]) if shape and len(shape) == 3 and isinstance(shape[1], int) else 1

    def metadata(self) -> PolicyMetadata:
        return PolicyMetadata(self.name, self.layout.action_dim, self.horizon, 1.0 / self.config.rate_hz,
                              extra={"input": self.in_name, "output": self.out_name})

    def reset(self) -> None:
        self.prev = None

    def prepare(self, obs: Observation, instruction: str | None) -> np.ndarray:
        parts = [state_value(obs, f) for f in self.config.obs_fields]
        self.current = np.asarray(obs.proprio, dtype=np.float64)
        if self.config.last_action:
            parts.append(self.prev if self.prev is not None else np.zeros(self.layout.action_dim))
        return np.concatenate(parts).astype(np.float32)[None, :]

    def infer(self, x: np.ndarray) -> np.ndarray:
        out = np.asarray(self.session.run([self.out_name], {self.in_name: x})[0], dtype=np.float64)
        out = out.reshape(-1, out.shape[-1])  # [D], [1, D], [1, H, D] -> [H, D]
        a = np.asarray(self.config.offset) + np.asarray(self.config.scale) * out
        if self.config.relative:
            a = a + self.current
        self.prev = a[0].copy()
        return a


OnnxConfig = OnnxPolicy.Config


class OnnxNode(PolicyNode):
    policy_class = OnnxPolicy
