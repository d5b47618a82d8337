"""The observation schema every embodiment reports (the RIO paper's appendix), in SI units.

Consumers (policies, recorders, visualizers, dataset exporters) read these dataclasses instead of
per-robot dicts, so one policy adapter or exporter works for every station of a morphology.

Units and conventions: positions in meters, angles in radians, time in seconds (`rio.clock.now()`);
poses are 7-vectors `[x, y, z, qw, qx, qy, qz]` (quaternion scalar first); gripper positions are the
finger opening in meters; RGB images are HxWx3 uint8; depth images are HxW float32 meters.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rio.errors import FrameGone

#: Lens distortion models a camera may publish (rio.interfaces.camera: the sample's `distortion_model` is the
#: index of one, `distortion` its 5 coefficients). The Brown-Conrady family takes [k1, k2, p1, p2, k3]
#: (OpenCV's first five; "inverse_brown_conrady" maps undistorted to distorted pixels, as RealSense colour
#: streams report), kannala_brandt4 [k1, k2, k3, k4, 0] (fisheye), ftheta [w, 0, 0, 0, 0]; "none": a
#: pinhole camera (or rectified images), coefficients zero.
DISTORTION_MODELS = ("none", "brown_conrady", "modified_brown_conrady", "inverse_brown_conrady", "kannala_brandt4",
                     "ftheta")


def camera_meta(s: Mapping[str, Any]) -> dict:
    """A camera sample's facts as `Camera.meta` gives them: timestamp, intrinsics (3x3) and, when the
    camera publishes its lens distortion, `distortion_model` (its name) and `distortion` (5,). Copies:
    `s` may be views into a ring slot."""
    meta: dict = {"timestamp": float(s["timestamp"])}
    if "intrinsics" in s:
        meta["intrinsics"] = np.array(s["intrinsics"])
    if "distortion" in s:
        meta["distortion_model"] = DISTORTION_MODELS[int(s["distortion_model"])]
        meta["distortion"] = np.array(s["distortion"], np.float64)
    return meta


def depth_meters(units: np.ndarray, depth_scale: float) -> np.ndarray:
    """A camera's depth (units of `depth_scale` m, as published) as float32 meters: the one conversion
    (the recorder's encoder repeats exactly this arithmetic, so a frame is stored the same either way)."""
    return units.astype(np.float32) * np.float32(depth_scale)


@dataclass
class Camera:
    rgb: np.ndarray | None = None
    depth: np.ndarray | None = None
    #: e.g. {"timestamp": float, "intrinsics": (3, 3) array, "source": where the frame lives
    #: (`rio.runtime.ring_ref`)}; a
    #: camera that publishes its lens distortion adds "distortion_model" (`DISTORTION_MODELS`), "distortion" (5,)
    meta: dict = field(default_factory=dict)

    @classmethod
    def from_sample(cls, s: dict) -> Camera:
        """A camera node's sample (`rio.interfaces.camera`: rgb, intrinsics; depth in units of
        `depth_scale`) as the schema's Camera (depth in float32 meters). The one conversion, used by
        `Env` and by a policy node reading frames by reference, so both see the same values."""
        depth: np.ndarray | None = None
        if "depth" in s:
            depth = depth_meters(s["depth"], s["depth_scale"])
        return cls(rgb=s["rgb"], depth=depth, meta=camera_meta(s))

    def kinds(self) -> tuple[str, ...]:
        """The images this frame has, of "rgb" and "depth", told without reading (or copying) them."""
        return tuple(k for k, v in (("rgb", self.rgb), ("depth", self.depth)) if v is not None)

    @contextmanager
    def in_place(self) -> Iterator[dict[str, Any]]:
        """The frame's pixels where they are, for a block that copies what it needs of them: "rgb" and,
        with depth, "depth" (here in meters; a `RingCamera` gives its camera's units and "depth_scale").
        Here they are this Camera's own arrays; see `RingCamera.in_place` for frames still in a ring."""
        yield {k: v for k, v in (("rgb", self.rgb), ("depth", self.depth)) if v is not None}


class RingCamera(Camera):
    """A frame still in its camera node's ring buffer: `meta` is complete at once, the pixels are copied
    out (checked, exactly the frame of `meta["timestamp"]`) the first time `rgb` or `depth` is read.

    Why: a control loop reads every camera each tick, but often nobody looks at the pixels — a policy
    node on the same machine takes them from the ring itself (`rio.policy.frames`), a teleop run without
    recording never does — and three 640x480 copies cost the tick ~0.5 ms before the observation can go
    out. A ring of N frames keeps N-1 (64 slots: ~2 s at 30 Hz); pixels first read later than that raise
    `rio.errors.FrameGone` rather than hand out another frame. Pickling takes the pixels.

    A consumer that copies the pixels somewhere anyway (the recorder into its encoder's ring, the live
    viewer into rerun's buffers) reads them where they are instead (`in_place`), so each frame is copied
    once, by the one who needs it, not copied out here first and again there."""

    def __init__(self, ring: Any, camera: str, meta: dict):
        self._ring, self._camera = ring, camera  # a rio.runtime.buffers.RingBuffer; the camera node's name
        self._taken = False
        self._rgb: np.ndarray | None = None
        self._depth: np.ndarray | None = None
        self.meta = meta

    def _gone(self, hint: str) -> FrameGone:
        return FrameGone(self._camera, float(self.meta["timestamp"]), self._ring.capacity, hint)

    def _take(self) -> None:
        if not self._taken:
            sample = self._ring.find(float(self.meta["timestamp"]))
            if sample is None:  # raised now and at every later read, never read as "no image"
                raise self._gone("read an observation's pixels within that many frames, or copy the ones you keep")
            cam = Camera.from_sample(sample)
            self._rgb, self._depth, self._taken = cam.rgb, cam.depth, True

    @contextmanager
    def in_place(self) -> Iterator[dict[str, Any]]:
        """The frame's sample as its camera published it (`rio.interfaces.camera`: depth in units of
        `depth_scale`, not meters) as read-only views into its ring slot, for a block that copies what it
        needs out of them. Checked when taken and again when the block ends: if the camera came round to
        the slot meanwhile, `FrameGone` is raised at the end of the block, and what the block copied must
        be dropped (it may mix two frames). Raises `FrameGone` at once if the frame is already gone.
        Pixels already taken (or replaced through `rgb`/`depth`) are given as `Camera.in_place` gives them."""
        if self._taken:
            with super().in_place() as own:
                yield own
            return
        found = self._ring.find_view(float(self.meta["timestamp"]))
        if found is None:
            raise self._gone("read its pixels sooner")
        sample, seq = found
        yield sample
        if not self._ring.holds(seq):
            raise self._gone("overwritten while it was being copied")

    def kinds(self) -> tuple[str, ...]:
        if self._taken:
            return super().kinds()
        return tuple(k for k in ("rgb", "depth") if k in self._ring.layout.names)

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
        return self._taken

    def __reduce__(self) -> Any:
        return Camera, (self.rgb, self.depth, self.meta)


#: Observation fields renamed since datasets were recorded and scripts written with them ({old: new}; Core v3
#: gave the gripper's opening one name, `width`). A dataset recorded before reads its columns under the new
#: names (`rio.recording.dataset.current_names`); a script or a policy's input map reading an old name gets the
#: new field, with one notice (`Observation.__getattr__`).
RENAMED_FIELDS = {"gripper_position": "gripper_width", "gripper1_position": "gripper1_width",
                  "gripper2_position": "gripper2_width"}


@dataclass
class Observation:
    #: Proprioception in the policy's action space (what `Env.step` takes, same order and units).
    proprio: np.ndarray
    #: Cameras by name: the station role without its "_camera" suffix ("front", "wrist").
    cameras: dict[str, Camera] = field(default_factory=dict)
    #: The environment's state where the station measures it (a sim world's object poses: privileged), the
    #: vector exports write as `observation.environment_state`. Filled only in the observation a policy
    #: receives (`rio deploy`, `rio eval`; `Env.environment_state`); the steps an `Env` returns, and so the
    #: recorder, keep it as the sensors' own values (`meta["sensors"]`).
    environment_state: np.ndarray | None = None

    def __getattr__(self, name: str) -> Any:
        """Only for names not found otherwise: an old field name (`RENAMED_FIELDS`) reads the new field."""
        new = RENAMED_FIELDS.get(name)
        if new is None:
            raise AttributeError(f"'{type(self).__name__}' object has no attribute '{name}'")
        from rio.config import notice_renamed  # here: rio.config brings pydantic, which a reader need not load

        notice_renamed(type(self).__name__, f"'{name}'", f"'{new}'")
        return getattr(self, new)


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
    gripper_width: float | None = None

    hand_pose: np.ndarray | None = None
    hand_joints: np.ndarray | None = None


@dataclass
class BimanualObs(Observation):
    # Left arm (station role "arm", "gripper", "hand")
    arm1_proprio_eef: np.ndarray | None = None
    arm1_proprio_joints: np.ndarray | None = None
    gripper1_width: float | None = None
    hand1_pose: np.ndarray | None = None
    hand1_joints: np.ndarray | None = None

    # Right arm (station role "arm2", "gripper2", "hand2")
    arm2_proprio_eef: np.ndarray | None = None
    arm2_proprio_joints: np.ndarray | None = None
    gripper2_width: float | None = None
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


@dataclass
class MobileManipulatorObs(SingleArmObs):
    """Not in the paper; follows its pattern: a single arm (and its gripper) on a mobile base. `proprio` is
    the arm's part then `base_twist`, as the action is laid out. The base's twist `[vx, vy, wz]` (m/s, rad/s)
    is in its own frame; `base_odom` `[x, y, theta]` (m, rad) is its odometry since it started."""

    base_twist: np.ndarray | None = None
    base_odom: np.ndarray | None = None
    base_wheel_pos: np.ndarray | None = None
    base_wheel_vel: np.ndarray | None = None
