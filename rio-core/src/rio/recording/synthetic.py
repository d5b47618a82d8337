"""Synthetic but camera-like data for tests and benchmarks: a textured, lit background with moving
shapes and sensor noise. Constant or random images would make compression figures meaningless
(one compresses to nothing, the other not at all); this compresses like a table-top scene.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio import clock
from rio.schema import Camera, SingleArmObs, Step


class SyntheticCamera:
    """Frames of a scene: gradient + fixed texture background, three moving discs, noise of std
    `noise` grey levels. `frame(t)` is deterministic for a given seed and time."""

    def __init__(self, height: int = 480, width: int = 640, seed: int = 0, noise: float = 1.5,
                 depth: bool = False):
        rng = np.random.default_rng(seed)
        self.h, self.w, self.noise, self.has_depth = height, width, noise, depth
        yy, xx = np.mgrid[0:height, 0:width]
        self.yy, self.xx = yy, xx
        base = np.stack([xx * 200 // max(width, 1) + 30, yy * 180 // max(height, 1) + 40,
                         np.full_like(xx, 110)], -1).astype(np.float32)
        texture = rng.normal(0, 10, (height // 4 + 1, width // 4 + 1, 1)).astype(np.float32)
        self.background = np.clip(base + np.repeat(np.repeat(texture, 4, 0), 4, 1)[:height, :width], 0, 255)
        self.rng = np.random.default_rng(seed + 1)
        self.colors = rng.integers(0, 255, (3, 3))
        self.phases = rng.uniform(0, 2 * np.pi, 3)

    def frame(self, t: float) -> np.ndarray:
        img = self.background.copy()
        for k in range(3):
            cx = self.w * (0.5 + 0.35 * np.sin(0.7 * (k + 1) * t + self.phases[k]))
            cy = self.h * (0.5 + 0.3 * np.cos(0.5 * (k + 1) * t + self.phases[k]))
            r = min(self.h, self.w) * (0.08 + 0.03 * k)
            img[(self.xx - cx) ** 2 + (self.yy - cy) ** 2 < r * r] = self.colors[k]
        if self.noise:
            img += self.rng.normal(0, self.noise, (self.h, self.w, 1)).astype(np.float32)
        return np.clip(img, 0, 255).astype(np.uint8)

    def depth(self, t: float) -> np.ndarray:
        """Depth in meters (float32, millimeter steps): a tilted plane with the discs 10 cm closer."""
        d = 0.6 + 0.4 * self.yy / max(self.h, 1) + 0.0 * t
        return (np.round(d * 1000) / 1000).astype(np.float32)


def synthetic_step(i: int, t: float, cameras: dict[str, tuple[np.ndarray, float]] | None = None,
                   dof: int = 6, instruction: str | None = "pick up the cube") -> Step:
    """A SingleArmObs step with smooth joint motion; `cameras` maps name -> (rgb, capture time)."""
    q = np.sin(0.5 * t + np.arange(dof) * 0.3)
    eef = np.array([0.3 + 0.1 * np.sin(t), 0.0, 0.2, 1.0, 0.0, 0.0, 0.0])
    grip = float(0.04 + 0.04 * np.sin(0.2 * t))
    cams = {name: Camera(rgb=rgb, meta={"timestamp": ts}) for name, (rgb, ts) in (cameras or {}).items()}
    obs = SingleArmObs(proprio=np.concatenate([q, [grip]]), proprio_eef=eef, proprio_joints=q,
                       gripper_width=grip, cameras=cams)
    action = np.concatenate([q + 0.01, [grip]])
    return Step(i, obs, instruction, action, {"t_obs": t, "timestamps": {"arm": t, "gripper": t},
                                              "station": "synthetic", "t_recv_wall": clock.now()})


def record_synthetic(root: str, episodes: int = 2, steps: int = 30, fps: float = 30.0, size: tuple[int, int] = (48, 64),
                     cameras: tuple[str, ...] = ("front", "wrist"), depth: bool = True, realtime: bool = False,
                     **recorder_kw) -> list[dict[str, Any]]:
    """Record a small synthetic dataset (tests, examples); returns the kept episodes' metadata.
    Times are `rio.clock.now()`-based; with `realtime=False` steps are simulated at `fps` without waiting."""
    from rio.recording.recorder import Recorder

    cams = {name: SyntheticCamera(*size, seed=k, noise=1.0, depth=depth and k == 0) for k, name in enumerate(cameras)}
    metas: list[dict[str, Any]] = []
    with Recorder(root, fps=fps, **recorder_kw) as rec:
        for _e in range(episodes):
            t0 = clock.now()
            rate = clock.Rate(fps) if realtime else None
            for i in range(steps):
                t = clock.now() if realtime else t0 + i / fps
                step = synthetic_step(i, t, {n: (c.frame(t), t) for n, c in cams.items()})
                for n, c in cams.items():
                    if c.has_depth:
                        step.observation.cameras[n].depth = c.depth(t)
                rec.add(step)
                if rate is not None:
                    rate.sleep()
            meta = rec.keep()
            if meta is not None:  # None only when steps=0: an empty episode is dropped, not kept
                metas.append(meta)
    return metas
