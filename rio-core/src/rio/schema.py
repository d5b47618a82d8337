"""The observation schema every embodiment reports (the RIO paper's appendix), in SI units.

Consumers (policies, recorders, visualizers, dataset exporters) read these dataclasses instead of
per-robot dicts, so one policy adapter or exporter works for every station of a morphology.

Units and conventions: positions in meters, angles in radians, time in seconds (`rio.clock.now()`);
poses are 7-vectors `[x, y, z, qw, qx, qy, qz]` (quaternion scalar first); gripper positions are the
finger opening in meters; RGB images are HxWx3 uint8; depth images are HxW float32 meters.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Camera:
    rgb: np.ndarray | None = None
    depth: np.ndarray | None = None
    #: e.g. {"timestamp": float, "intrinsics": (3, 3) array, "source": where the frame lives (`rio.ring_ref`)}
    meta: dict = field(default_factory=dict)

    @classmethod
    def from_sample(cls, s: dict) -> Camera:
        """A camera node's sample (`rio.interfaces.camera`: rgb, intrinsics; depth in units of
        `depth_scale`) as the schema's Camera (depth in float32 meters). The one conversion, used by
        `Env` and by a policy node reading frames by reference, so both see the same values."""
        depth: np.ndarray | None = None
        if "depth" in s:
            depth = s["depth"].astype(np.float32) * np.float32(s["depth_scale"])
        meta: dict = {"timestamp": float(s["timestamp"])}
        if "intrinsics" in s:
            meta["intrinsics"] = np.asarray(s["intrinsics"])
        return cls(rgb=s["rgb"], depth=depth, meta=meta)


class RingCamera(Camera):
    """A frame still in its camera node's ring buffer: `meta` is complete at once, the pixels are copied
    out (checked, exactly the frame of `meta["timestamp"]`) the first time `rgb` or `depth` is read.

    Why: a control loop reads every camera each tick, but often nobody looks at the pixels — a policy
    node on the same machine takes them from the ring itself (`rio.policy.frames`), a teleop run without
    recording never does — and three 640x480 copies cost the tick ~0.5 ms before the observation can go
    out. A ring of N frames keeps N-1 (64 slots: ~2 s at 30 Hz); pixels first read later than that raise
    `rio.errors.FrameGone` rather than hand out another frame. Pickling takes the pixels."""

    def __init__(self, load: Any, meta: dict):
        self._load = load  # () -> Camera (the sample converted), raising FrameGone
        self._rgb: np.ndarray | None = None
        self._depth: np.ndarray | None = None
        self.meta = meta

    def _take(self) -> None:
        if self._load is not None:
            cam = self._load()  # a frame gone raises now and at every later read, never gives None
            self._rgb, self._depth, self._load = cam.rgb, cam.depth, None

    @property
    def rgb(self) -> np.ndarray | None:
        self._take()
        return self._rgb

    @rgb.setter
    def rgb(self, value: np.ndarray | None) -> None:
        self._take()
        self._rgb = value

    @property
    def depth(self) -> np.ndarray | None:
        self._take()
        return self._depth

    @depth.setter
    def depth(self, value: np.ndarray | None) -> None:
        self._take()
        self._depth = value

    @property
    def taken(self) -> bool:
        """Whether the pixels have been copied out of the ring."""
        return self._load is None

    def __reduce__(self) -> Any:
        return Camera, (self.rgb, self.depth, self.meta)


@dataclass
class Observation:
    #: Proprioception in the policy's action space (what `Env.step` takes, same order and units).
    proprio: np.ndarray
    #: Cameras by name: the station role without its "_camera" suffix ("front", "wrist").
    cameras: dict[str, Camera] = field(default_factory=dict)


@dataclass
class Step:
    timestep: int | None
    observation: Observation
    instruction: str | None
    action: np.ndarray | None
    meta: dict | None = field(default_factory=dict)


@dataclass
class SingleArmObs(Observation):
    proprio_eef: np.ndarray | None = None
    proprio_joints: np.ndarray | None = None
    gripper_position: float | None = None

    hand_pose: np.ndarray | None = None
    hand_joints: np.ndarray | None = None


@dataclass
class BimanualObs(Observation):
    # Left arm (station role "arm", "gripper", "hand")
    arm1_proprio_eef: np.ndarray | None = None
    arm1_proprio_joints: np.ndarray | None = None
    gripper1_position: float | None = None
    hand1_pose: np.ndarray | None = None
    hand1_joints: np.ndarray | None = None

    # Right arm (station role "arm2", "gripper2", "hand2")
    arm2_proprio_eef: np.ndarray | None = None
    arm2_proprio_joints: np.ndarray | None = None
    gripper2_position: float | None = None
    hand2_pose: np.ndarray | None = None
    hand2_joints: np.ndarray | None = None


@dataclass
class HumanoidObs(Observation):
    """Not in the paper; follows its pattern. Base orientation from the IMU, quaternion wxyz."""

    joint_pos: np.ndarray | None = None
    joint_vel: np.ndarray | None = None
    base_quat: np.ndarray | None = None
    base_ang_vel: np.ndarray | None = None

    hand1_joints: np.ndarray | None = None
    hand2_joints: np.ndarray | None = None
