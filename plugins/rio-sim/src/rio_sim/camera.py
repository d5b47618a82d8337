"""`sim.camera`: a camera of a sim world behind the standard `CameraNode` interface (RGB, optional
metric depth as uint16 millimeters, pinhole intrinsics).

Each camera node renders in its own thread or process with its own OpenGL context: it copies the
world's joint positions from the bus, updates kinematics on its own copy of the scene and renders,
so cameras run in parallel with physics and with each other, at their own rate.

Defaults (320x240 at 30 Hz) hold their rate on a CPU with Mesa (a frame costs a few milliseconds
there); raise `width`/`height` in the station file for larger images. Without OpenGL the camera
logs why, with the fix, and publishes mid-gray frames with `rendered = False` (set
`require_gl = true` to fail the station instead).
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from pydantic import Field

from rio.interfaces import CameraNode

from .attached import WorldAttachment
from .gl import CONTEXT_LOCK, gl_problem

log = logging.getLogger("rio_sim.camera")

#: Depth beyond this (m) is "no reading" (0), as depth cameras report it.
MAX_DEPTH_M = 10.0


class SimCamera(CameraNode):
    class Config(CameraNode.Config):
        camera: str = Field("front", description="scene camera: 'front', or '<arm>/wrist' (e.g. arm/wrist)")
        world: str = Field("sim", description="the sim.world it looks at")
        width: int = Field(320, ge=16, le=1280)
        height: int = Field(240, ge=16, le=960)
        depth: bool = Field(False, description="also render metric depth (uint16 mm, depth_scale 0.001)")
        require_gl: bool = Field(False, description="fail instead of publishing placeholder frames without OpenGL")

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.camera, self.require_gl = c.camera, c.require_gl
        self.sim = WorldAttachment(c.world)
        self.example_data["rendered"] = True
        self.renderer = None

    def open(self) -> None:
        import mujoco

        self._mj = mujoco
        self.sim.attach()
        self.model = self.sim.model
        names = [self.model.camera(i).name for i in range(self.model.ncam)]
        if self.camera not in names:
            raise ValueError(f"scene '{self.sim.bus.scene}' has no camera '{self.camera}'; cameras: {names}")
        self.data = mujoco.MjData(self.model)
        fovy = math.radians(float(self.model.camera(self.camera).fovy[0]))
        f = 0.5 * self.height / math.tan(fovy / 2)
        self.k = np.array([[f, 0.0, self.width / 2], [0.0, f, self.height / 2], [0.0, 0.0, 1.0]])
        problem = gl_problem()
        if problem is not None:
            if self.require_gl:
                raise RuntimeError(f"camera '{self.camera}': {problem}")
            log.warning("camera '%s' publishes placeholder frames: %s", self.camera, problem)
            self._placeholder = {"rgb": np.full((self.height, self.width, 3), 128, np.uint8), "intrinsics": self.k,
                                 "rendered": False}
            if self.has_depth:
                self._placeholder.update(depth=np.zeros((self.height, self.width), np.uint16), depth_scale=0.001)
            return
        with CONTEXT_LOCK:
            self.renderer = mujoco.Renderer(self.model, self.height, self.width)

    def close(self) -> None:
        if self.renderer is not None:
            with CONTEXT_LOCK:
                self.renderer.close()
            self.renderer = None
        self.sim.detach()

    def read_state(self) -> dict[str, Any]:
        if self.renderer is None:
            self.sim.bus.check_alive()
            return self._placeholder
        mj, m, d = self._mj, self.model, self.data
        d.qpos[:] = self.sim.state()["qpos"]
        mj.mj_kinematics(m, d)
        mj.mj_camlight(m, d)
        r = self.renderer
        r.update_scene(d, camera=self.camera)
        out: dict[str, Any] = {"rgb": r.render(), "intrinsics": self.k, "rendered": True}
        if self.has_depth:
            r.enable_depth_rendering()
            r.update_scene(d, camera=self.camera)
            z = r.render()
            r.disable_depth_rendering()
            mm = np.where((z > 0) & (z < MAX_DEPTH_M), np.round(z * 1000.0), 0.0)
            out["depth"], out["depth_scale"] = mm.astype(np.uint16), 0.001
        return out
