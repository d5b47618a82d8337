"""Logging to rerun, shared by `rio teleop --viz` (a live run: camera frames, depth, joint positions,
tool poses) and `rio datasets view` (a recorded episode, `rio.recording.view`).

rerun-sdk is optional (`pip install rio-sim[viz]`, or `pip install rerun-sdk`); without it
`make_viz` says so once and returns None, and the run goes on. With a display rerun's viewer is
spawned; headless (Linux with no DISPLAY or WAYLAND_DISPLAY, e.g. over SSH or in CI) the stream is
saved to an .rrd file to open later with `rerun FILE.rrd`.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

import numpy as np

INSTALL_HINT = "pip install rerun-sdk"


def load_rerun() -> Any | None:
    """The `rerun` module, or None when rerun-sdk is not installed."""
    try:
        import rerun as rr
    except ImportError:
        return None
    return rr


def headless() -> bool:
    """No display to spawn rerun's viewer on: Linux with neither DISPLAY nor WAYLAND_DISPLAY set."""
    return sys.platform.startswith("linux") and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY")


class RerunViz:
    """One rerun recording, spawned in the viewer or saved to `save_path`, with the logging calls both
    users need (rerun API differences between versions handled here, once)."""

    def __init__(self, rr: Any, app: str, save_path: str | None):
        self.rr, self.where = rr, save_path or "viewer"
        rr.init(app)
        if save_path:
            rr.save(save_path)
        else:
            rr.spawn()
        self._scalars = getattr(rr, "Scalars", None) or rr.Scalar

    def time(self, t: float, it: int) -> None:
        """Timelines: "step" (sequence) and "time" (seconds, a duration from the start)."""
        rr = self.rr
        if hasattr(rr, "set_time"):
            rr.set_time("step", sequence=it)
            rr.set_time("time", duration=t)
        else:  # older rerun
            rr.set_time_sequence("step", it)
            rr.set_time_seconds("time", t)

    def image(self, path: str, rgb: np.ndarray, jpeg_quality: int | None = None) -> None:
        """An RGB frame; `jpeg_quality` stores it JPEG-compressed (a recording of many frames stays small)."""
        img = self.rr.Image(rgb)
        self.rr.log(path, img.compress(jpeg_quality=jpeg_quality) if jpeg_quality else img)

    def depth(self, path: str, depth: np.ndarray, meter: float = 1.0) -> None:
        """A depth frame; `meter`: how many of its units make a meter (1.0: it is in meters)."""
        self.rr.log(path, self.rr.DepthImage(depth, meter=meter))

    def camera(self, path: str, cam: Any) -> None:
        """A step's camera frame (`rio.schema.Camera`): `path`/rgb and `path`/depth. The pixels are read
        where they are (`Camera.in_place`: the camera node's ring slot, no copy out first) and copied
        once, into rerun's own buffers, as its archetypes are made; they are logged only if the slot
        still held that frame afterwards. A frame gone from the ring is skipped: the viewer shows the
        next one. Depth goes as the camera's integers with their scale (rerun's `meter`), not meters."""
        from rio.errors import FrameGone

        rr = self.rr
        try:
            with cam.in_place() as px:
                logs = []
                if (rgb := px.get("rgb")) is not None:
                    logs.append((f"{path}/rgb", rr.Image(rgb)))
                if (depth := px.get("depth")) is not None:
                    scale = px.get("depth_scale")
                    meter = 1.0 if scale is None else 1.0 / float(scale)
                    logs.append((f"{path}/depth", rr.DepthImage(depth, meter=meter)))
        except FrameGone:
            return
        for where, archetype in logs:
            rr.log(where, archetype)

    def scalar(self, path: str, value: float) -> None:
        self.rr.log(path, self._scalars(float(value)))

    def pose(self, path: str, pose: np.ndarray) -> None:
        """A pose [x, y, z, qw, qx, qy, qz] as a transform (position only when it has 3 values)."""
        rr, pose = self.rr, np.asarray(pose, np.float64)
        if len(pose) >= 7:
            rr.log(path, rr.Transform3D(translation=pose[:3], quaternion=rr.Quaternion(
                xyzw=[pose[4], pose[5], pose[6], pose[3]])))
        else:
            rr.log(path, rr.Transform3D(translation=pose[:3]))

    def axes(self, path: str, length: float) -> None:
        """Show the transform at `path` as three arrows of `length` (static: once for the whole recording)."""
        rr = self.rr
        if hasattr(rr, "TransformAxes3D"):
            rr.log(path, rr.TransformAxes3D(axis_length=length), static=True)
        else:  # older rerun: the axes are a Transform3D component
            rr.log(path, rr.Transform3D(axis_length=length), static=True)

    def static(self, path: str, archetype: Any) -> None:
        self.rr.log(path, archetype, static=True)

    def log(self, t: float, it: int, step: Any, arms: list[Any]) -> None:
        """One teleop tick: the step's camera frames and each arm's joints, tool pose, target, gripper."""
        rr = self.rr
        self.time(t, it)
        for name, cam in step.observation.cameras.items():
            self.camera(f"cameras/{name}", cam)
        for b in arms:
            s = b.client.get_state()
            for i, q in enumerate(np.asarray(s["joint_pos"])):
                self.scalar(f"{b.role}/joints/{i}", q)
            self.pose(f"{b.role}/tool", s["eef_pose"])
            rr.log(f"{b.role}/tool_target", rr.Points3D([b.target[:3]], radii=0.005))
            if b.gripper is not None:
                self.scalar(f"{b.role}/gripper", b.gripper.get_state()["width"])

    def close(self) -> None:
        try:
            self.rr.disconnect()
        except Exception:
            pass


def make_viz(station: str, save_path: str | None = None, warn=print) -> RerunViz | None:
    rr = load_rerun()
    if rr is None:
        warn(f"--viz: rerun-sdk is not installed ({INSTALL_HINT}); running without visualization")
        return None
    if save_path is None and headless():
        save_path = f"teleop-{station}-{time.strftime('%Y%m%d-%H%M%S')}.rrd"
    return RerunViz(rr, f"rio_teleop_{station}", save_path)
