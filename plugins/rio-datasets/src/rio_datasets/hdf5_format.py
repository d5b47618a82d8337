"""HDF5 in the two layouts imitation-learning code reads:

ALOHA (act, lerobot's aloha converters): one file per episode, OUT/episode_<k>.hdf5
    /action                       (T, A)
    /observations/qpos            (T, S)   proprio
    /observations/<field>         (T, ...) other observation fields (proprio_eef, ...)
    /observations/environment_state (T, E) the environment state (a simulator's object poses); attrs `names`
    /observations/wrench_<sensor> (T, 6) a force/torque sensor's fx fy fz (N) tx ty tz (N m)
    /observations/images/<cam>    (T, H, W, 3) uint8
    /observations/depth/<cam>     (T, H, W) uint16 (depth_unit_m units)
    attrs: sim=False, fps, rio (JSON), robot_type (the station's arm driver, when recorded)
    every numeric dataset (action, qpos, <field>): attrs `names` (JSON), one per element: the drivers'
    joint names, `gripper`, `x` ... `qz`, the objects' `cube.x` ...

robomimic: one file, OUT.hdf5
    /data/demo_<k>/actions, /obs/<field> (proprio as `state`, the environment state as `object`, robomimic's
    name for it; attrs `names`), /obs/<cam>_image, /obs/<cam>_depth, /rewards, /dones;  attrs num_samples;
    /data attrs total, env_args (JSON);  /mask/train

Row t holds the observation fields and the environment state read at step t and the action issued after
that observation (`common`: native actions shifted by one). Images are gzip-compressed chunks of one frame
(lossless); state keeps its dtype (exact).

Every file is written through `hdf5_file.GuardedFile`, so an I/O error (a full disk) never reaches the
HDF5 library's close path (where it crashed the process): it ends the export as one error line.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.config import Config
from rio.recording import Dataset
from rio.recording.format import DatasetFormat, Progress

from .common import (
    ENVIRONMENT_STATE,
    ExportError,
    check_same_layout,
    common_fps,
    element_names,
    image_streams,
    lowdim,
    rio_attrs,
    robot_type,
    select,
)
from .hdf5_file import GuardedFile
from .native_writer import episode_steps, name_environment_state, open_recorder

#: The environment state's dataset in each style.
ENV_KEY = {"aloha": "environment_state", "robomimic": "object"}


def _frames(ep: Any, cam: str, kind: str) -> np.ndarray:
    return np.stack(list(ep.step_frames(cam, kind)))


@contextlib.contextmanager
def _new_file(path: Path) -> Iterator[tuple[Any, Callable[[], None]]]:
    """(an h5py File being written at `path`, check): `check()` raises the I/O error the file kept, if any
    (see `hdf5_file`); called after each dataset and, here, once the file is closed."""
    import h5py

    guard = GuardedFile(path)
    try:
        with h5py.File(guard, "w") as f:
            yield f, guard.check
    finally:
        guard.close()
    guard.check()


class Hdf5Format(DatasetFormat):
    name = "hdf5"
    can_import = True

    class Config(Config):
        style: Literal["aloha", "robomimic"] = Field("aloha", description="ALOHA (a file per episode) or robomimic "
                                                          "(data/demo_N in one file)")
        depth: bool = Field(True, description="export depth streams")
        compression: int = Field(4, ge=0, le=9, description="gzip level for images (0: none)")

    def _image(self, group: Any, name: str, x: np.ndarray) -> None:
        kw = {"compression": "gzip", "compression_opts": self.config.compression} if self.config.compression else {}
        group.create_dataset(name, data=x, chunks=(1, *x.shape[1:]), **kw)

    def _write_episode(self, ep: Any, obs: Any, top: Any, aloha: bool, check: Callable[[], None]) -> None:
        cols = lowdim(ep)
        t = cols.pop("t")
        action = cols.pop("action", None)
        def names(field: str, x: np.ndarray) -> str:
            """The `names` attribute (JSON): one per element, the drivers' joints, `gripper`, `cube.x` ..."""
            return json.dumps(element_names([ep], field, int(np.prod(x.shape[1:]))))

        if action is not None:
            top.create_dataset("action" if aloha else "actions", data=action).attrs["names"] = names("action", action)
        for field, x in cols.items():
            name = ("qpos" if aloha else "state") if field == "proprio" else field
            if field == ENVIRONMENT_STATE:
                name = ENV_KEY["aloha" if aloha else "robomimic"]
            obs.create_dataset(name, data=x).attrs["names"] = names(field, x)
        obs.create_dataset("timestamp", data=t - t[0])
        check()
        for cam, kind in image_streams(ep, depth=self.config.depth):
            x = _frames(ep, cam, kind)
            if aloha:
                self._image(obs.require_group("images" if kind == "rgb" else "depth"), cam, x)
            else:
                self._image(obs, f"{cam}_{'image' if kind == 'rgb' else 'depth'}", x)
            check()
        top.attrs["rio"] = json.dumps(rio_attrs(ep))
        if (robot := robot_type([ep])) is not None:
            top.attrs["robot_type"] = robot

    def export(self, dataset: Dataset, out: Path, *, episodes: list[int] | None = None,
               progress: Progress | None = None) -> dict[str, Any]:
        eps = select(dataset, episodes)
        check_same_layout(eps)
        fps = common_fps(eps)
        out = Path(out)
        total, done = sum(len(e) for e in eps), 0
        if self.config.style == "aloha":
            out.mkdir(parents=True, exist_ok=True)
            if any(out.glob("episode_*.hdf5")):
                raise ExportError(f"{out} already holds episode_*.hdf5 files")
            for k, ep in enumerate(eps):
                with _new_file(out / f"episode_{k}.hdf5") as (f, check):
                    f.attrs["sim"], f.attrs["fps"] = False, fps
                    self._write_episode(ep, f.create_group("observations"), f, aloha=True, check=check)
                done += len(ep)
                if progress:
                    progress(done, total, f"episode {ep.index}")
            return {"episodes": len(eps), "steps": total, "style": "aloha", "path": str(out)}
        if out.exists():
            raise ExportError(f"{out} already exists")
        with _new_file(out) as (f, check):
            data = f.create_group("data")
            for k, ep in enumerate(eps):
                demo = data.create_group(f"demo_{k}")
                n = len(ep)
                demo.attrs["num_samples"] = n
                self._write_episode(ep, demo.create_group("obs"), demo, aloha=False, check=check)
                demo.create_dataset("rewards", data=np.zeros(n))
                dones = np.zeros(n, np.int64)
                dones[-1] = 1
                demo.create_dataset("dones", data=dones)
                done += n
                if progress:
                    progress(done, total, f"episode {ep.index}")
            data.attrs["total"] = total
            data.attrs["env_args"] = json.dumps({"env_name": eps[0].meta.get("station") or "rio", "type": 0,
                                                 "env_kwargs": {"control_freq": fps}})
            data.attrs["fps"] = fps
            f.create_dataset("mask/train", data=np.array([f"demo_{k}".encode() for k in range(len(eps))]))
        return {"episodes": len(eps), "steps": total, "style": "robomimic", "path": str(out)}

    def import_(self, src: Path, out: Path, *, progress: Progress | None = None) -> dict[str, Any]:
        import h5py

        src = Path(src)
        if src.is_dir():  # ALOHA: one file per episode
            files = sorted(src.glob("episode_*.hdf5"), key=lambda p: int(p.stem.split("_")[1]))
            handles = [(h5py.File(p, "r"), None) for p in files]
            episodes = [(f, f, f["observations"], True) for f, _ in handles]
        else:
            f = h5py.File(src, "r")
            handles = [(f, None)]
            demos = sorted(f["data"], key=lambda s: int(s.split("_")[1]))
            episodes = [(f, f["data"][d], f["data"][d]["obs"], False) for d in demos]
        if not episodes:
            raise ExportError(f"{src}: no episodes found")
        try:
            first_rio = json.loads(episodes[0][1].attrs.get("rio", "{}"))
            fps = float(first_rio.get("fps") or episodes[0][0].attrs.get("fps")
                        or (episodes[0][0]["data"].attrs.get("fps") if "data" in episodes[0][0] else None) or 50.0)
            total = done = 0
            with open_recorder(Path(out), fps, first_rio) as rec:
                for k, (_, top, obs, aloha) in enumerate(episodes):
                    meta = json.loads(top.attrs.get("rio", "{}"))
                    low: dict[str, np.ndarray] = {}
                    act = "action" if aloha else "actions"
                    if act in top:
                        low["action"] = top[act][()]
                    images: dict[tuple[str, str], Any] = {}
                    env_key = ENV_KEY["aloha" if aloha else "robomimic"]
                    env_names = json.loads(obs[env_key].attrs.get("names", "[]")) if env_key in obs else None
                    for name, item in obs.items():
                        if isinstance(item, h5py.Group):  # aloha images/ and depth/
                            for cam, d in item.items():
                                images[(cam, "rgb" if name == "images" else "depth")] = iter(d[()])
                        elif name.endswith(("_image", "_depth")):
                            cam, kind = name.rsplit("_", 1)
                            images[(cam, "rgb" if kind == "image" else "depth")] = iter(item[()])
                        elif name == env_key:
                            low[ENVIRONMENT_STATE] = item[()]
                        elif name != "timestamp":
                            low["proprio" if name in ("qpos", "state") else name] = item[()]
                    units = {s["camera"]: s.get("depth_unit_m") or 0.001 for s in meta.get("streams", {}).values()}
                    t = obs["timestamp"][()] if "timestamp" in obs else None
                    if ENVIRONMENT_STATE in low:
                        env = low[ENVIRONMENT_STATE]
                        name_environment_state(rec, meta, env.reshape(len(env), -1).shape[1], env_names or None)
                    for step in episode_steps(low, images, fps, meta.get("instruction"),
                                              meta.get("observation_class"), units, t, rio_meta=meta,
                                              env_names=env_names or None):
                        rec.add(step)
                    rec.keep({"imported_from": str(src)})
                    n = len(next(iter(low.values())))
                    total += n
                    done += n
                    if progress:
                        progress(k + 1, len(episodes), f"episode {k}")
        finally:
            for h, _ in handles:
                h.close()
        return {"episodes": len(episodes), "steps": total, "path": str(out)}


Hdf5Config = Hdf5Format.Config
