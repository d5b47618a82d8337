"""openpi (pi0, pi0.5) served by `openpi`'s own policy server, reached over its websocket protocol
(`openpi_wire`), spoken here directly so no openpi-client (which pins numpy<2) is needed.

The observation dict is built from the station's observation by name: `images` maps openpi keys to
camera names, `state` maps keys to observation fields (see `rio_policies.inputs`), and the
instruction goes under `prompt_key`. For the DROID checkpoints, for example:

    --policy 'openpi.remote,host=gpu1,port=8000,rate_hz=15,image_size=[224,224],
      images={"observation/exterior_image_1_left":"front","observation/wrist_image_left":"wrist"},
      state={"observation/joint_position":"proprio_joints","observation/gripper_position":"gripper_width"}'
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.policy import Policy, PolicyConfig, PolicyMetadata, PolicyNode
from rio.schema import Observation

from . import openpi_wire
from .inputs import camera_image, default_images, state_value


class OpenPIPolicy(Policy):
    name = "openpi.remote"
    class Config(PolicyConfig):
        host: str = Field("127.0.0.1", description="policy server host, or a ws:// URI")
        port: int | None = Field(8000, description="policy server port (None when host is a full URI)")
        api_key: str | None = Field(None, description="sent as 'Authorization: Api-Key ...' when set")
        images: dict[str, str] | None = Field(None, description="openpi image key -> camera name "
                                                                "(default: observation/<camera>_image)")
        image_size: list[int] | None = Field(None, min_length=2, max_length=2,
                                             description="[H, W]: resize with padding before sending")
        state: dict[str, str] = Field(default_factory=lambda: {"observation/state": "proprio"},
                                      description="openpi state key -> observation field or 'proprio[a:b]'")
        prompt_key: str = "prompt"
        actions_key: str = "actions"
        rate_hz: float = Field(50.0, gt=0, description="actions per second of the model's chunks")
        chunk: int = Field(50, ge=1, description="expected chunk length (informational; replies decide)")
        connect_timeout_s: float = Field(30.0, gt=0)

    def setup(self) -> None:
        self.ws: Any = None
        self.server_metadata: dict = {}

    def uri(self) -> str:
        c = self.config
        base = c.host if c.host.startswith("ws") else f"ws://{c.host}"
        return base if c.port is None else f"{base}:{c.port}"

    def load(self, layout: Any) -> None:
        from websockets.sync.client import connect

        super().load(layout)
        headers = {"Authorization": f"Api-Key {self.config.api_key}"} if self.config.api_key else None
        self._conn = connect(self.uri(), compression=None, max_size=None, additional_headers=headers,
                             open_timeout=self.config.connect_timeout_s)
        self.ws = self._conn.__enter__()
        meta = openpi_wire.unpackb(self.ws.recv())
        self.server_metadata = meta if isinstance(meta, dict) else {}

    def metadata(self) -> PolicyMetadata:
        c = self.config
        images = default_images(self.layout.cameras, c.images, "observation/{camera}_image")
        return PolicyMetadata(self.name, self.layout.action_dim, c.chunk, 1.0 / c.rate_hz,
                              cameras=sorted(set(images.values())),
                              extra={"server": {str(k): str(v) for k, v in self.server_metadata.items()}})

    def prepare(self, obs: Observation, instruction: str | None) -> dict[str, Any]:
        c = self.config
        out: dict[str, Any] = {}
        for key, cam in default_images(obs.cameras, c.images, "observation/{camera}_image").items():
            out[key] = camera_image(obs, cam, c.image_size)
        for key, ref in c.state.items():
            out[key] = state_value(obs, ref)
        if instruction is not None:
            out[c.prompt_key] = instruction
        return out

    def infer(self, inputs: dict[str, Any]) -> np.ndarray:
        self.ws.send(openpi_wire.packb(inputs))
        reply = self.ws.recv()
        if isinstance(reply, str):
            raise RuntimeError(f"openpi server {self.uri()} failed:\n{reply}")
        out = openpi_wire.unpackb(reply)
        if self.config.actions_key not in out:
            raise RuntimeError(f"openpi server reply has no '{self.config.actions_key}' (keys: {sorted(out)})")
        return np.asarray(out[self.config.actions_key])

    def close(self) -> None:
        if self.ws is not None:
            self._conn.__exit__(None, None, None)
            self.ws = None


OpenPIConfig = OpenPIPolicy.Config


class OpenPINode(PolicyNode):
    policy_class = OpenPIPolicy
