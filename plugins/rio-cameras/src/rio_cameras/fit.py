"""Bring a grabbed frame to the size the station asked for.

The ring buffer's slot is fixed by the config's width x height before the device is opened, but a device
may deliver another size (a webcam that did not accept the mode, a phone streaming portrait, depth at a
lower resolution than colour). Resizing here keeps the contract's shapes; the intrinsics are scaled with
the image so they stay true for the published pixels. Aspect-ratio changes stretch the image: the
drivers warn about them when they learn the delivered size.
"""

from __future__ import annotations

import numpy as np

from .frames import Frame


def scale_intrinsics(k: np.ndarray, sx: float, sy: float) -> np.ndarray:
    """K for an image scaled by (sx, sy). Pixel centres map as (u + 0.5) * s - 0.5, hence the shift."""
    out = np.array(k, dtype=np.float64, copy=True)
    out[0, 0] *= sx
    out[0, 1] *= sx
    out[1, 1] *= sy
    out[0, 2] = (out[0, 2] + 0.5) * sx - 0.5
    out[1, 2] = (out[1, 2] + 0.5) * sy - 0.5
    return out


def resize(img: np.ndarray, width: int, height: int, nearest: bool = False) -> np.ndarray:
    """cv2.resize with the interpolation that suits the content: area for shrinking colour, linear for
    enlarging it, nearest for depth (interpolating depth invents distances across object edges)."""
    import cv2

    h, w = img.shape[:2]
    if (w, h) == (width, height):
        return img
    if nearest:
        interp = cv2.INTER_NEAREST
    else:
        interp = cv2.INTER_AREA if width * height < w * h else cv2.INTER_LINEAR
    return cv2.resize(img, (width, height), interpolation=interp)


def fit_frame(frame: Frame, width: int, height: int) -> Frame:
    """`frame` with rgb (and depth) at width x height and its intrinsics scaled to match."""
    h, w = frame.rgb.shape[:2]
    k = frame.intrinsics
    if k is not None and (w, h) != (width, height):
        k = scale_intrinsics(k, width / w, height / h)
    depth = None if frame.depth is None else resize(frame.depth, width, height, nearest=True)
    return Frame(rgb=resize(frame.rgb, width, height), t=frame.t, depth=depth,
                 depth_scale=frame.depth_scale, intrinsics=k)
