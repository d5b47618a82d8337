"""One grabbed frame as every driver hands it to the grab thread, and the depth conversion the depth
drivers share. Drivers differ in what their SDK returns; after this point they are all the same."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Frame:
    #: (h, w, 3) uint8, RGB order (drivers convert from their SDK's BGR/BGRA here, not later).
    rgb: np.ndarray
    #: `rio.clock.now()` when the frame was taken from the device: the sample's timestamp.
    t: float
    #: (h', w') uint16, in units of `depth_scale` meters; None when the driver has no depth.
    depth: np.ndarray | None = None
    depth_scale: float = 0.001
    #: 3x3 pinhole matrix in pixels of *this* `rgb` (None: the driver has no calibration to offer).
    intrinsics: np.ndarray | None = None


def metric_to_u16(depth: np.ndarray, unit_m: float, scale: float = 0.001) -> np.ndarray:
    """Float depth in units of `unit_m` meters (ZED: 0.001 with UNIT.MILLIMETER; Record3D: 1.0) to
    uint16 in units of `scale` meters. NaN, inf and non-positive values (the SDKs' "no reading") become 0,
    as depth cameras report a missing reading; values beyond the uint16 range saturate."""
    d = np.asarray(depth, dtype=np.float32) * np.float32(unit_m / scale)
    d = np.where(np.isfinite(d) & (d > 0), d, 0.0)
    return np.clip(np.rint(d), 0, 65535).astype(np.uint16)
