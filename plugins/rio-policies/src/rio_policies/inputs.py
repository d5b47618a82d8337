"""Building a model's inputs from a standard `Observation`: the pieces every adapter needs.

Adapters name what they send by the observation's own vocabulary, so one config line maps a station
to a model: a state entry is an `Observation` field (`proprio`, `proprio_joints`, `gripper_width`,
...) or a slice of `proprio` written `"proprio[0:6]"`; an image entry is a camera name.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from rio.schema import Observation

_SLICE = re.compile(r"^(\w+)\[(-?\d*):(-?\d*)\]$")


def state_value(obs: Observation, ref: str) -> np.ndarray:
    """`ref` = 'field' or 'field[a:b]' -> a 1-D float array."""
    m = _SLICE.match(ref)
    name = m.group(1) if m else ref
    if not hasattr(obs, name) or getattr(obs, name) is None:
        raise ValueError(f"the observation ({type(obs).__name__}) has no '{name}'")
    v = np.atleast_1d(np.asarray(getattr(obs, name), dtype=np.float64))
    if m:
        a, b = (int(x) if x else None for x in m.groups()[1:])
        v = v[a:b]
    return v


def camera_image(obs: Observation, camera: str, size: list[int] | None = None) -> np.ndarray:
    """RGB uint8 image of `camera`, resized with padding to `size` = [H, W] when given."""
    if camera not in obs.cameras or obs.cameras[camera].rgb is None:
        raise ValueError(f"the station has no camera '{camera}' (cameras: {sorted(obs.cameras)})")
    img = np.asarray(obs.cameras[camera].rgb)
    return resize_with_pad(img, size[0], size[1]) if size else img


def resize_with_pad(img: np.ndarray, height: int, width: int) -> np.ndarray:
    """Keep the aspect ratio, scale (nearest pixel) to fit, pad with black: what VLA servers expect
    (pi0 and GR00T train on letterboxed 224x224 frames)."""
    h, w = img.shape[:2]
    if (h, w) == (height, width):
        return img
    s = min(height / h, width / w)
    nh, nw = max(1, round(h * s)), max(1, round(w * s))
    rows = np.minimum((np.arange(nh) / s).astype(np.int64), h - 1)
    cols = np.minimum((np.arange(nw) / s).astype(np.int64), w - 1)
    out = np.zeros((height, width) + img.shape[2:], img.dtype)
    top, left = (height - nh) // 2, (width - nw) // 2
    out[top:top + nh, left:left + nw] = img[rows][:, cols]
    return out


def default_images(obs_cameras: Any, mapping: dict[str, str] | None, key: str) -> dict[str, str]:
    """The model key -> camera mapping; by default every camera under `key.format(camera=name)`."""
    if mapping is not None:
        return dict(mapping)
    return {key.format(camera=name): name for name in obs_cameras}
