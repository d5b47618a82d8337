"""`--viz`: stream a teleop run to rerun (camera frames, depth, joint positions, tool poses).

rerun-sdk is optional (`pip install rio-sim[viz]`, or `pip install rerun-sdk`); without it
`make_viz` says so once and returns None, and the run goes on. With a display rerun's viewer is
spawned; headless (no DISPLAY, e.g. over SSH or in CI) the stream is saved to an .rrd file to open
later with `rerun FILE.rrd`.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np


class RerunViz:
    def __init__(self, rr: Any, app: str, save_path: str | None):
        self.rr, self.where = rr, save_path or "viewer"
        rr.init(app)
        if save_path:
            rr.save(save_path)
        else:
            rr.spawn()
        self._scalars = getattr(rr, "Scalars", None) or rr.Scalar

    def _time(self, t: float, it: int) -> None:
        rr = self.rr
        if hasattr(rr, "set_time"):
            rr.set_time("step", sequence=it)
            rr.set_time("time", duration=t)
        else:  # older rerun
            rr.set_time_sequence("step", it)
            rr.set_time_seconds("time", t)

    def log(self, t: float, it: int, step: Any, arms: list[Any]) -> None:
        rr = self.rr
        self._time(t, it)
        for name, cam in step.observation.cameras.items():
            if cam.rgb is not None:
                rr.log(f"cameras/{name}/rgb", rr.Image(cam.rgb))
            if cam.depth is not None:
                rr.log(f"cameras/{name}/depth", rr.DepthImage(np.asarray(cam.depth, np.float32), meter=1.0))
        for b in arms:
            s = b.client.get_state()
            for i, q in enumerate(np.asarray(s["joint_pos"])):
                rr.log(f"{b.role}/joints/{i}", self._scalars(float(q)))
            pose = np.asarray(s["eef_pose"])
            rr.log(f"{b.role}/tool", rr.Transform3D(translation=pose[:3], quaternion=rr.Quaternion(
                xyzw=[pose[4], pose[5], pose[6], pose[3]])))
            rr.log(f"{b.role}/tool_target", rr.Points3D([b.target[:3]], radii=0.005))
            if b.gripper is not None:
                rr.log(f"{b.role}/gripper", self._scalars(float(b.gripper.get_state()["position"])))

    def close(self) -> None:
        try:
            self.rr.disconnect()
        except Exception:
            pass


def make_viz(station: str, save_path: str | None = None, warn=print) -> RerunViz | None:
    try:
        import rerun as rr
    except ImportError:
        warn("--viz: rerun-sdk is not installed (pip install rerun-sdk); running without visualization")
        return None
    if save_path is None and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        save_path = f"teleop-{station}-{time.strftime('%Y%m%d-%H%M%S')}.rrd"
    return RerunViz(rr, f"rio_teleop_{station}", save_path)
