"""RIO samples -> ROS 2 messages (pure functions of a sample; no I/O).

Stamps: RIO stamps every sample with its one monotonic clock (`rio.clock.now()`), which means nothing
on another machine. ROS stamps are wall-clock time (what a ROS node's system clock gives: seconds
since the UNIX epoch), so each sample's stamp is moved onto the wall clock by the offset between the
two clocks measured when it is published (`wall_stamp`): a message says when its sample was taken,
not when it was sent.

Poses: RIO's `[x, y, z, qw, qx, qy, qz]` (m, base frame) -> ROS's position + quaternion (x, y, z, w).
"""

from __future__ import annotations

import io
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from rio import clock

from .messages import MessageTypes

_EMPTY = np.zeros(0, dtype=np.float64)


def wall_stamp(t_mono: float) -> float:
    """A `rio.clock.now()` time as wall-clock seconds (UNIX epoch)."""
    return float(t_mono) + (time.time() - clock.now())


def joint_state(types: MessageTypes, names: Sequence[str], sample: Any, stamp: float) -> Any:
    """`sensor_msgs/JointState`: positions, and velocities where the driver measured them all."""
    vel = np.asarray(sample.get("joint_vel", _EMPTY), dtype=np.float64)
    return types.make("sensor_msgs/msg/JointState", header=types.header(stamp, ""), name=list(names),
                      position=np.asarray(sample["joint_pos"], dtype=np.float64).copy(),
                      velocity=vel.copy() if vel.size == len(names) and np.isfinite(vel).all() else _EMPTY,
                      effort=_EMPTY)


def _pose(types: MessageTypes, p: np.ndarray) -> Any:
    return types.make("geometry_msgs/msg/Pose",
                      position=types.make("geometry_msgs/msg/Point", x=p[0], y=p[1], z=p[2]),
                      orientation=_quaternion(types, p))


def _quaternion(types: MessageTypes, p: np.ndarray) -> Any:
    return types.make("geometry_msgs/msg/Quaternion", x=p[4], y=p[5], z=p[6], w=p[3])


def has_pose(sample: Any) -> bool:
    """The arm reports an end-effector pose (measured or by forward kinematics; NaN when it has neither)."""
    pose = sample.get("eef_pose")
    return pose is not None and bool(np.isfinite(pose).all())


def pose_stamped(types: MessageTypes, pose: Any, frame_id: str, stamp: float) -> Any:
    p = np.asarray(pose, dtype=np.float64).reshape(7)
    return types.make("geometry_msgs/msg/PoseStamped", header=types.header(stamp, frame_id), pose=_pose(types, p))


def transform(types: MessageTypes, pose: Any, parent: str, child: str, stamp: float) -> Any:
    """`geometry_msgs/TransformStamped` of `child` in `parent` (one entry of a `tf2_msgs/TFMessage`)."""
    p = np.asarray(pose, dtype=np.float64).reshape(7)
    tf = types.make("geometry_msgs/msg/Transform",
                    translation=types.make("geometry_msgs/msg/Vector3", x=p[0], y=p[1], z=p[2]),
                    rotation=_quaternion(types, p))
    return types.make("geometry_msgs/msg/TransformStamped", header=types.header(stamp, parent),
                      child_frame_id=child, transform=tf)


def tf_message(types: MessageTypes, transforms: list[Any]) -> Any:
    return types.make("tf2_msgs/msg/TFMessage", transforms=transforms)


def image(types: MessageTypes, pixels: np.ndarray, frame_id: str, stamp: float) -> Any:
    """`sensor_msgs/Image`: an (H, W, 3) uint8 frame as `rgb8`; an (H, W) float32 depth map in meters as
    `32FC1` (REP 118), little endian."""
    px = np.ascontiguousarray(pixels)
    if px.ndim == 3 and px.shape[2] == 3 and px.dtype == np.uint8:
        encoding = "rgb8"
    elif px.ndim == 2 and px.dtype == np.float32:
        encoding, px = "32FC1", px.astype("<f4", copy=False)
    else:
        raise ValueError(f"no ROS image encoding for a {px.dtype} frame of shape {px.shape}")
    h, w = px.shape[:2]
    return types.make("sensor_msgs/msg/Image", header=types.header(stamp, frame_id), height=h, width=w,
                      encoding=encoding, is_bigendian=0, step=px.strides[0],
                      data=px.reshape(-1).view(np.uint8))


def compressed_image(types: MessageTypes, rgb: np.ndarray, frame_id: str, stamp: float, quality: int = 90) -> Any:
    """`sensor_msgs/CompressedImage`: JPEG, described as image_transport's `compressed` plugin does."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb), "RGB").save(buf, "JPEG", quality=int(quality))
    return types.make("sensor_msgs/msg/CompressedImage", header=types.header(stamp, frame_id),
                      format="rgb8; jpeg compressed bgr8", data=np.frombuffer(buf.getvalue(), dtype=np.uint8))


def camera_info(types: MessageTypes, intrinsics: Any, width: int, height: int, frame_id: str, stamp: float) -> Any:
    """`sensor_msgs/CameraInfo` of a pinhole camera with no distortion (RIO frames carry K only)."""
    k = np.asarray(intrinsics, dtype=np.float64).reshape(3, 3)
    p = np.hstack([k, np.zeros((3, 1))])
    roi = types.make("sensor_msgs/msg/RegionOfInterest", x_offset=0, y_offset=0, height=0, width=0,
                     do_rectify=False)
    return types.make("sensor_msgs/msg/CameraInfo", header=types.header(stamp, frame_id), height=int(height),
                      width=int(width), distortion_model="plumb_bob", d=np.zeros(5), k=k.reshape(-1),
                      r=np.eye(3).reshape(-1), p=p.reshape(-1), binning_x=0, binning_y=0, roi=roi)
