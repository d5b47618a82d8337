"""NVIDIA Isaac-GR00T (N1.5, N1.6) served by its own inference service, reached over its ZMQ
request/reply protocol (`gr00t_wire`), spoken here directly (no gr00t package needed).

`protocol="n1.5"` sends GR00T N1.5's flat observation (`video.<k>` [1, H, W, 3] uint8,
`state.<k>` [1, D], `annotation.human.task_description` [text]) to `get_action` and reads back
`action.<k>` [H, D]; `"n1.6"` sends N1.6's nested one (`{"video": {k: [1, 1, H, W, 3]}, "state":
{k: [1, 1, D]}, "language": {key: [[text]]}}` under `data.observation`) and reads `[actions, info]`.
The station's action vector is the concatenation of `action_keys`, in that order. For a G1 upper body:

    --policy 'gr00t.remote,port=5555,rate_hz=30,video={"ego_view":"head"},
      state={"left_arm":"proprio[0:7]","right_arm":"proprio[7:14]"},action_keys=["left_arm","right_arm"]'
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.policy import Policy, PolicyConfig, PolicyMetadata, PolicyNode
from rio.schema import Observation

from . import gr00t_wire
from .inputs import camera_image, default_images, state_value

LANGUAGE_KEY = "annotation.human.task_description"


class Gr00tPolicy(Policy):
    name = "gr00t.remote"
    class Config(PolicyConfig):
        host: str = "127.0.0.1"
        port: int = 5555
        api_token: str | None = None
        timeout_ms: int = Field(15000, ge=1, description="a reply slower than this is an error")
        protocol: Literal["n1.5", "n1.6"] = "n1.5"
        video: dict[str, str] | None = Field(None, description="GR00T video key -> camera (default: camera names)")
        image_size: list[int] | None = Field(None, min_length=2, max_length=2)
        state: dict[str, str] = Field(default_factory=lambda: {"state": "proprio"},
                                      description="GR00T state key -> observation field or 'proprio[a:b]'")
        action_keys: list[str] | None = Field(None, description="action keys concatenated into the station's "
                                                                "action (default: every key, sorted)")
        language_key: str = LANGUAGE_KEY
        rate_hz: float = Field(30.0, gt=0)
        chunk: int = Field(16, ge=1)

    def setup(self) -> None:
        self.ctx = self.sock = None

    def _connect(self) -> None:
        import zmq

        if self.sock is not None:
            self.sock.close(linger=0)
        self.sock = self.ctx.socket(zmq.REQ)
        self.sock.setsockopt(zmq.RCVTIMEO, self.config.timeout_ms)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.connect(f"tcp://{self.config.host}:{self.config.port}")

    def call(self, endpoint: str, data: Any = None, with_data: bool = True) -> Any:
        import zmq

        self.sock.send(gr00t_wire.request(endpoint, data, self.config.api_token, with_data))
        try:
            reply = gr00t_wire.unpackb(self.sock.recv())
        except zmq.Again:
            self._connect()  # a REQ socket that missed its reply cannot send again
            raise TimeoutError(f"GR00T server tcp://{self.config.host}:{self.config.port} did not answer "
                               f"'{endpoint}' within {self.config.timeout_ms} ms") from None
        if isinstance(reply, dict) and "error" in reply:
            raise RuntimeError(f"GR00T server error on '{endpoint}': {reply['error']}")
        return reply

    def load(self, layout: Any) -> None:
        import zmq

        super().load(layout)
        self.ctx = zmq.Context()
        self._connect()
        self.call("ping", with_data=False)

    def metadata(self) -> PolicyMetadata:
        c = self.config
        cams = default_images(self.layout.cameras, c.video, "{camera}")
        return PolicyMetadata(self.name, self.layout.action_dim, c.chunk, 1.0 / c.rate_hz,
                              cameras=sorted(set(cams.values())), extra={"protocol": c.protocol})

    def prepare(self, obs: Observation, instruction: str | None) -> Any:
        c = self.config
        video = {k: camera_image(obs, cam, c.image_size)[None] for k, cam in
                 default_images(obs.cameras, c.video, "{camera}").items()}
        state = {k: state_value(obs, ref)[None] for k, ref in c.state.items()}
        text = instruction or ""
        if c.protocol == "n1.5":
            flat: dict[str, Any] = {f"video.{k}": v for k, v in video.items()}
            flat.update({f"state.{k}": v for k, v in state.items()})
            flat[c.language_key] = [text]
            return flat
        return {"observation": {"video": {k: v[None] for k, v in video.items()},
                                "state": {k: v[None].astype(np.float32) for k, v in state.items()},
                                "language": {c.language_key: [[text]]}},
                "options": None}

    def infer(self, inputs: Any) -> np.ndarray:
        reply = self.call("get_action", inputs)
        actions = reply[0] if isinstance(reply, (list, tuple)) else reply
        parts = {str(k).removeprefix("action."): np.asarray(v) for k, v in actions.items()}
        keys = self.config.action_keys or sorted(parts)
        missing = [k for k in keys if k not in parts]
        if missing:
            raise RuntimeError(f"GR00T reply lacks action keys {missing} (has {sorted(parts)})")
        cols = []
        for k in keys:
            a = parts[k]
            while a.ndim > 2 and a.shape[0] == 1:  # batch (and N1.6's time) axes of one
                a = a[0]
            cols.append(a.reshape(a.shape[0], -1))
        return np.concatenate(cols, axis=1)

    def reset(self) -> None:
        if self.sock is not None and self.config.protocol == "n1.6":
            self.call("reset", {"options": None})

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close(linger=0)
            self.ctx.term()
            self.sock = self.ctx = None


Gr00tConfig = Gr00tPolicy.Config


class Gr00tNode(PolicyNode):
    policy_class = Gr00tPolicy
