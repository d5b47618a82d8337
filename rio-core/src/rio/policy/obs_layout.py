"""The station's observation as one fixed-size request record, so it reaches the policy process the
way every RIO request travels: packed once into a slot of the node's request queue (shared memory
under `shm`; raw bytes on network middlewares). Nothing is pickled or re-serialized, and the policy
process rebuilds the very same `Observation` subclass.

Camera frames travel one of two ways, fixed per camera when the layout is made:
- by reference, when the observation's camera says where its frame lives (`Camera.meta["source"]`, set
  by `Env` when the camera's middleware shares rings: `shm`, `thread`): the request carries only the
  frame's timestamp and the policy node reads the frame from the camera's ring (`rio.policy.frames`);
- by copy otherwise (network middlewares), or when asked (`copying()`, the policy node's `frames="copy"`):
  the frames are copied into the request as uint8 arrays.

Inputs that are not observations (a teleop device's twist as a locomotion policy's velocity command)
travel the camera-frame way: `inputs` names the rings of such station nodes (role -> `rio.runtime.ring_ref`
reference, filled in by `rio deploy` for the station's teleop devices where the middleware shares rings),
and a policy that wants one reads its newest sample in place (`rio.runtime.ring_ref.SharedRing`).

`ObsLayout.of(observation)` reads the layout off a first observation (its class, every array or scalar
field it fills, each camera's shapes and source), so one layout works for any embodiment. It is plain
JSON, which is how it travels to the policy node's constructor (`observation=layout.to_dict()`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rio.errors import InvalidRequest
from rio.plugins.specs import import_path
from rio.schema import Camera, Observation

if TYPE_CHECKING:
    from rio.policy.frames import CameraFrames

#: Request field names: observation fields, camera images and their capture times, then the rest.
_F, _RGB, _DEPTH, _CAM_T = "o.", "rgb.", "depth.", "tcam."


@dataclass
class ObsLayout:
    obs_type: str
    #: Observation fields (proprio first) -> shape; a scalar field has shape [].
    fields: dict[str, list[int]]
    #: Camera name -> {"rgb": [H, W, 3]} plus "depth": [H, W] when the camera has depth, plus "source": a
    #: `rio.runtime.ring_ref` reference when its frames go by reference.
    cameras: dict[str, dict[str, Any]] = field(default_factory=dict)
    instruction_bytes: int = 256
    #: Station role -> ring reference of a node a policy may read in place (see the module docstring).
    inputs: dict[str, dict[str, Any]] = field(default_factory=dict)

    # -- building -----------------------------------------------------------------------------------
    @classmethod
    def of(cls, obs: Observation, instruction_bytes: int = 256) -> ObsLayout:
        fields: dict[str, list[int]] = {}
        for f in dataclasses.fields(obs):
            if f.name == "cameras":
                continue
            v = getattr(obs, f.name)
            if v is None:
                continue
            arr = np.asarray(v)
            if arr.dtype.kind not in "biuf":
                continue
            fields[f.name] = list(arr.shape)
        cams = {}
        for name, cam in obs.cameras.items():
            cams[name] = {"rgb": list(np.asarray(cam.rgb).shape)}
            if cam.depth is not None:
                cams[name]["depth"] = list(np.asarray(cam.depth).shape)
            if cam.meta.get("source") is not None:
                cams[name]["source"] = cam.meta["source"]
        t = type(obs)
        return cls(f"{t.__module__}:{t.__qualname__}", fields, cams, instruction_bytes)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ObsLayout:
        return cls(**d)

    def copying(self) -> ObsLayout:
        """This layout with every camera's frames copied into the request (no references)."""
        cams = {name: {k: v for k, v in c.items() if k != "source"} for name, c in self.cameras.items()}
        return dataclasses.replace(self, cameras=cams)

    @property
    def sources(self) -> dict[str, dict[str, Any]]:
        """Camera name -> ring reference, for the cameras whose frames go by reference."""
        return {name: c["source"] for name, c in self.cameras.items() if c.get("source") is not None}

    @property
    def action_dim(self) -> int:
        """`Observation.proprio` is in the action space, so its size is the action size."""
        shape = self.fields.get("proprio")
        if not shape:
            raise ValueError(f"observation type {self.obs_type} has no proprio vector")
        return int(shape[0])

    # -- the request record -------------------------------------------------------------------------
    def example_request(self) -> dict[str, Any]:
        ex: dict[str, Any] = {_F + k: np.zeros(s) for k, s in self.fields.items()}
        for name, c in self.cameras.items():
            if c.get("source") is None:
                ex[_RGB + name] = np.zeros(c["rgb"], np.uint8)
                if "depth" in c:
                    ex[_DEPTH + name] = np.zeros(c["depth"], np.float32)
            ex[_CAM_T + name] = 0.0
        ex.update(instruction=np.zeros(self.instruction_bytes, np.uint8), instruction_len=0,
                  t_obs=0.0, seq=0, reset=False)
        return ex

    def encode(self, obs: Observation, instruction: str | None, t_obs: float, seq: int,
               reset: bool = False) -> dict[str, Any]:
        """The request for `obs` (the values are referenced, not copied: the queue copies them once). A
        camera whose frames go by reference contributes only its frame's timestamp: the policy node reads
        the frame the camera published then, not `cam.rgb` (edit images in the policy's `prepare`)."""
        req: dict[str, Any] = {_F + k: getattr(obs, k) for k in self.fields}
        for name, c in self.cameras.items():
            cam = obs.cameras[name]
            if c.get("source") is None:
                req[_RGB + name] = cam.rgb
                if "depth" in c:
                    req[_DEPTH + name] = cam.depth
                req[_CAM_T + name] = float(cam.meta.get("timestamp", t_obs))
            elif "timestamp" not in cam.meta:
                raise InvalidRequest("policy", _CAM_T + name, "a camera whose frames go by reference needs its "
                                                               "frame's timestamp in meta['timestamp']")
            else:
                req[_CAM_T + name] = float(cam.meta["timestamp"])
        text = (instruction or "").encode()[: self.instruction_bytes]
        buf = np.zeros(self.instruction_bytes, np.uint8)
        buf[: len(text)] = np.frombuffer(text, np.uint8)
        req.update(instruction=buf, instruction_len=len(text), t_obs=float(t_obs), seq=int(seq), reset=bool(reset))
        return req

    def pack(self, rec: np.ndarray, values: dict[str, Any], owner: str = "policy") -> np.ndarray:
        """Write `encode()`'s values into a reusable request record (`rec`, of the queue's dtype)
        instead of a freshly allocated one: a new 3-camera record costs ~1.5 ms in page faults on
        every request, a reused one a plain copy. Checks what `Layout.encode` would: shapes, and
        NaN/inf in the state fields."""
        for k, v in values.items():
            arr = np.asarray(v)
            if arr.shape != rec.dtype[k].shape:
                raise InvalidRequest(owner, k, f"expected shape {rec.dtype[k].shape}, got {arr.shape}")
            if k.startswith(_F) and arr.dtype.kind in "fc" and not np.isfinite(arr).all():
                raise InvalidRequest(owner, k, "contains NaN or inf")
            rec[k] = arr
        return rec

    def decode(self, req: dict[str, Any], frames: CameraFrames | None = None,
               ) -> tuple[Observation, str | None, float, int, bool]:
        """A request back into (observation, instruction, t_obs, seq, reset); frames that go by reference
        are taken from `frames` (raises `rio.policy.frames.FrameGone` for one no longer there)."""
        cls = import_path(self.obs_type)
        values = {}
        for k, shape in self.fields.items():
            v = np.asarray(req[_F + k])
            values[k] = float(v) if not shape else v
        cams = {}
        for name, c in self.cameras.items():
            t_cam = float(req[_CAM_T + name])
            if c.get("source") is not None:
                if frames is None:
                    raise InvalidRequest("policy", _RGB + name, "its frames go by reference: decode needs the "
                                                                "camera rings (rio.policy.frames.CameraFrames)")
                cams[name] = frames.take(name, t_cam)
                continue
            depth = req[_DEPTH + name] if "depth" in c else None
            cams[name] = Camera(rgb=req[_RGB + name], depth=depth, meta={"timestamp": t_cam})
        n = int(req["instruction_len"])
        text = bytes(np.asarray(req["instruction"])[:n]).decode(errors="replace") if n else None
        return cls(cameras=cams, **values), text, float(req["t_obs"]), int(req["seq"]), bool(req["reset"])
