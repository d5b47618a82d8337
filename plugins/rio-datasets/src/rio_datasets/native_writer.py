"""Imports write native datasets through the real `Recorder`, so imported data gets the same
layout, encoding and durability as recorded data. This module turns per-episode arrays into Steps: it
pairs actions back the native way (`common.native_actions`) and puts an exported environment state back
into the step columns it came from (`environment_layout`)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from rio.recording import Recorder
from rio.recording.flatten import load_class
from rio.schema import RENAMED_FIELDS, Camera, Observation, Step

from .common import ENVIRONMENT_STATE, WRENCH_PREFIX, native_actions

#: Where an environment state from a dataset made elsewhere goes (no RIO layout says where it came from).
FOREIGN_ENVIRONMENT_STATE = "meta.environment_state"


def environment_layout(rio_meta: dict[str, Any] | None, width: int,
                       names: list[str] | None = None) -> dict[str, dict[str, Any]]:
    """{native column: {"names", "shape"}} to split an imported (T, width) environment state into: the
    layout a RIO export recorded (`common.environment_layout`), else one column of its own."""
    layout = (rio_meta or {}).get(ENVIRONMENT_STATE)
    if layout:
        return layout
    return {FOREIGN_ENVIRONMENT_STATE: {"names": list(names or [f"{ENVIRONMENT_STATE}.{i}" for i in range(width)]),
                                        "shape": [width]}}


def _nest(meta: dict[str, Any], column: str, value: Any) -> None:
    parts = column.split(".")[1:]  # "meta.sensors.world.object_poses" -> meta["sensors"]["world"]["object_poses"]
    for p in parts[:-1]:
        meta = meta.setdefault(p, {})
    meta[parts[-1]] = value


def episode_steps(lowdim: dict[str, np.ndarray], images: dict[tuple[str, str], Iterable[np.ndarray]], fps: float,
                  instruction: str | None, observation_class: str | None,
                  depth_unit_m: dict[str, float] | None = None, t: np.ndarray | None = None,
                  rio_meta: dict[str, Any] | None = None, env_names: list[str] | None = None) -> Iterator[Step]:
    """Steps of one episode: `lowdim` has "action" (paired with the observation it followed, as exported),
    observation fields ("proprio", ...) and perhaps "environment_state" (named `env_names` when the data
    comes from elsewhere) and `wrench_<sensor>` fields (6 each: back into `meta.sensors.<sensor>.force` /
    `.torque`); `images` maps (camera, kind) to one frame per step (depth as uint16 units or float
    meters). `rio_meta`: what a RIO export recorded of the episode (`common.rio_attrs`)."""
    cls: type[Observation] = load_class(observation_class, Observation) if observation_class else Observation
    fields = set(cls.__dataclass_fields__)
    n = len(next(iter(lowdim.values())))
    times = np.arange(n) / fps if t is None else np.asarray(t, dtype=np.float64)
    # an export made before a field was renamed (`gripper_position`) imports under today's name
    lowdim = {RENAMED_FIELDS.get(k, k): v for k, v in lowdim.items()}
    if "action" in lowdim:
        lowdim["action"] = native_actions(np.asarray(lowdim["action"]), (rio_meta or {}).get("first_action"))
    env = lowdim.pop(ENVIRONMENT_STATE, None)
    columns: list[tuple[str, np.ndarray]] = []
    if env is not None:
        env = np.asarray(env).reshape(n, -1)
        start = 0
        for col, spec in environment_layout(rio_meta, env.shape[1], env_names).items():
            size = len(spec["names"])
            columns.append((col, env[:, start:start + size].astype(np.float64).reshape(n, *spec["shape"])))
            start += size
    for name in [k for k in lowdim if k.startswith(WRENCH_PREFIX)]:  # back into the sensor's own columns
        w, sensor = np.asarray(lowdim.pop(name), dtype=np.float64).reshape(n, 6), name[len(WRENCH_PREFIX):]
        columns += [(f"meta.sensors.{sensor}.force", w[:, :3]), (f"meta.sensors.{sensor}.torque", w[:, 3:])]
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
        meta: dict[str, Any] = {"t_obs": float(times[i])}
        for col, x in columns:
            _nest(meta, col, x[i])
        yield Step(i, cls(cameras=cams, **kw), instruction, action, meta)


def open_recorder(out: Path, fps: float, info: dict[str, Any] | None = None, video: Any = None,
                  camera_fps: Any = None) -> Recorder:
    rec = Recorder(out, fps=fps, video=video, camera_fps=camera_fps, station=(info or {}).get("station"))
    for k in ("embodiment", "robot_type", "action_names", "observation_names", "action_parts"):
        if (info or {}).get(k) is not None:
            rec.info[k] = info[k]
    return rec


def name_environment_state(rec: Recorder, rio_meta: dict[str, Any] | None, width: int,
                           names: list[str] | None = None) -> None:
    """Name the environment state of the episodes `rec` will write, as the recorder names a station's."""
    rec.info[ENVIRONMENT_STATE] = {col: spec["names"] for col, spec in
                                   environment_layout(rio_meta, width, names).items()}
