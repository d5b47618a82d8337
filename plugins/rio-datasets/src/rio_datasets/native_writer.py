"""Imports write native datasets through the real `Recorder`, so imported data gets the same
layout, encoding and durability as recorded data. This module turns per-episode arrays into Steps."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from rio.recording import Recorder
from rio.recording.flatten import load_class
from rio.schema import Camera, Observation, Step


def episode_steps(lowdim: dict[str, np.ndarray], images: dict[tuple[str, str], Iterable[np.ndarray]], fps: float,
                  instruction: str | None, observation_class: str | None,
                  depth_unit_m: dict[str, float] | None = None, t: np.ndarray | None = None) -> Iterator[Step]:
    """Steps of one episode: `lowdim` has "action" and observation fields ("proprio", ...);
    `images` maps (camera, kind) to one frame per step (depth as uint16 units or float meters)."""
    cls: type[Observation] = load_class(observation_class) if observation_class else Observation
    fields = set(cls.__dataclass_fields__)
    n = len(next(iter(lowdim.values())))
    times = np.arange(n) / fps if t is None else np.asarray(t, dtype=np.float64)
    iters = {k: iter(v) for k, v in images.items()}
    for i in range(n):
        kw: dict[str, Any] = {}
        for name, col in lowdim.items():
            if name in ("action", "t") or name not in fields:
                continue
            v = col[i]
            kw[name] = v.item() if np.ndim(v) == 0 else np.array(v)
        kw.setdefault("proprio", np.zeros(0))
        cams: dict[str, Camera] = {}
        for (cam, kind), it in iters.items():
            frame = next(it)
            if kind == "depth" and frame.dtype == np.uint16:
                frame = frame.astype(np.float32) * np.float32((depth_unit_m or {}).get(cam, 0.001))
            c = cams.setdefault(cam, Camera(meta={"timestamp": float(times[i])}))
            setattr(c, kind, frame)
        action = np.array(lowdim["action"][i]) if "action" in lowdim else None
        yield Step(i, cls(cameras=cams, **kw), instruction, action, {"t_obs": float(times[i])})


def open_recorder(out: Path, fps: float, info: dict[str, Any] | None = None, video: Any = None,
                  camera_fps: Any = None) -> Recorder:
    rec = Recorder(out, fps=fps, video=video, camera_fps=camera_fps, station=(info or {}).get("station"))
    for k in ("embodiment", "action_names", "action_parts"):
        if (info or {}).get(k) is not None:
            rec.info[k] = info[k]
    return rec
