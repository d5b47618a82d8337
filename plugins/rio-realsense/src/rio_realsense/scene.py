"""The scene a software RealSense looks at: a wall 1 m away and a 20 cm square plate 80 cm away that
swings left and right (period 4 s of frame time), seen in colour as a red/green gradient (red grows
to the right, green downward, blue 64) with the plate white.

Both streams are rendered from the same geometry with each stream's own intrinsics and position
(colour sits `baseline_m` to the right of the depth origin, as on a D435), so aligning depth to colour
with the SDK has a right answer: the depth this module renders directly from the colour camera. Scene
time is the frame number over the frame rate, so any frame can be re-rendered exactly by a test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

WALL_M = 1.0
PLATE_M = 0.8
PLATE_SIDE_M = 0.2
SWING_M = 0.15
PERIOD_S = 4.0


@dataclass(frozen=True)
class Pinhole:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def from_hfov(cls, width: int, height: int, hfov_deg: float) -> Pinhole:
        """Square pixels, principal point at the centre of the image."""
        f = width / 2 / math.tan(math.radians(hfov_deg) / 2)
        return cls(width, height, f, f, (width - 1) / 2, (height - 1) / 2)

    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


def plate_x(t_s: float) -> float:
    """The plate's centre (m, along x in the depth camera's frame) at scene time `t_s`."""
    return SWING_M * math.sin(2 * math.pi * t_s / PERIOD_S)


def plate_mask(cam: Pinhole, t_s: float, cam_x: float = 0.0) -> np.ndarray:
    """(H, W) bool: where a camera at x = `cam_x` (looking along +z) sees the plate."""
    u = (np.arange(cam.width) - cam.cx) / cam.fx * PLATE_M + cam_x
    v = (np.arange(cam.height) - cam.cy) / cam.fy * PLATE_M
    half = PLATE_SIDE_M / 2
    return (np.abs(v) <= half)[:, None] & (np.abs(u - plate_x(t_s)) <= half)[None, :]


def depth_m(cam: Pinhole, t_s: float, cam_x: float = 0.0) -> np.ndarray:
    """(H, W) float32 z-depth in meters seen by a camera at x = `cam_x`."""
    return np.where(plate_mask(cam, t_s, cam_x), np.float32(PLATE_M), np.float32(WALL_M)).astype(np.float32)


def color(cam: Pinhole, t_s: float, cam_x: float = 0.0) -> np.ndarray:
    """(H, W, 3) uint8 rgb: the gradient, with the plate white."""
    h, w = cam.height, cam.width
    img = np.empty((h, w, 3), np.uint8)
    img[..., 0] = np.round(np.arange(w) * (255 / max(w - 1, 1))).astype(np.uint8)[None, :]
    img[..., 1] = np.round(np.arange(h) * (255 / max(h - 1, 1))).astype(np.uint8)[:, None]
    img[..., 2] = 64
    img[plate_mask(cam, t_s, cam_x)] = 255
    return img
