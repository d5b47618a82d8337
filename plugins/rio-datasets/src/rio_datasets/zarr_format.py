"""Zarr replay buffer, the Diffusion Policy / UMI layout:

    OUT.zarr/
      data/action            (N, A)        every step of every episode, concatenated
      data/state             (N, S)        proprio (the policy's action space)
      data/<field>           (N, ...)      other observation fields (proprio_eef, gripper_width, ...);
                                           every numeric array's attrs `names`: one per element (the
                                           drivers' joint names, `gripper`, `x` ... `qz`)
      data/environment_state (N, E)        the environment state (a simulator's object poses), float64;
                                           its attrs `names`: one per element (cube.x, ..., cube.qz, ...)
      data/wrench_<sensor>   (N, 6)        a force/torque sensor's fx fy fz (N) tx ty tz (N m), float64
      data/timestamp         (N,)          seconds since the episode start
      data/<camera>_rgb      (N, H, W, 3)  uint8, one chunk per frame
      data/<camera>_depth    (N, H, W)     uint16 in depth_unit_m units (lossless)
      meta/episode_ends      (E,)          cumulative step counts (episode k = [ends[k-1], ends[k]))

Row i holds the observation fields and the environment state read at step i and `action`, the command
issued after that observation (`common`: native actions shifted by one).

Written as Zarr format 2 (what diffusion_policy's and UMI's zarr<3 ReplayBuffer open); root
attributes hold `rio` (fps, instructions, layout) so an import restores the episodes exactly.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from rio.config import Config
from rio.machine.confine import inside
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
from .native_writer import episode_steps, name_environment_state, open_recorder


def _zarr():
    try:
        import zarr
    except ImportError as e:  # Python 3.10: zarr 3 needs 3.11+
        raise ExportError("the Zarr format needs the 'zarr' package (Python 3.11+): pip install zarr") from e
    return zarr


def _settle(timeout_s: float = 30.0) -> None:
    """Wait for the writes zarr still has under way on its IO thread. When one chunk write fails (a full
    disk), zarr raises at once while the chunks written with it go on in the background: a partial output
    removed then would be written again behind the cleanup. Best effort: zarr's own loop, if it has one."""
    import asyncio

    try:
        from zarr.core import sync
    except ImportError:
        return
    loop = sync.loop[0]
    if loop is None or not loop.is_running():
        return

    async def pending() -> None:
        me = asyncio.current_task()
        tasks = [t for t in asyncio.all_tasks() if t is not me]
        if tasks:
            await asyncio.wait(tasks, timeout=timeout_s)

    try:
        asyncio.run_coroutine_threadsafe(pending(), loop).result(timeout_s + 5)
    except Exception:  # noqa: BLE001 - the cleanup goes on; nothing more can be done here
        pass


def _name(field: str) -> str:
    return "state" if field == "proprio" else field


class ZarrFormat(DatasetFormat):
    name = "zarr"
    can_import = True

    class Config(Config):
        depth: bool = Field(True, description="export depth streams")
        compression_level: int = Field(5, ge=0, le=9, description="Blosc zstd level")

    def export(self, dataset: Dataset, out: Path, *, episodes: list[int] | None = None,
               progress: Progress | None = None) -> dict[str, Any]:
        zarr = _zarr()
        eps = select(dataset, episodes)
        check_same_layout(eps)
        fps = common_fps(eps)
        out = Path(out)
        if out.exists():
            raise ExportError(f"{out} already exists")
        try:
            return self._write(zarr, eps, fps, out, progress)
        except BaseException:
            _settle()  # zarr's writes still under way would recreate files after the cleanup
            raise

    def _write(self, zarr: Any, eps: list, fps: float, out: Path, progress: Progress | None) -> dict[str, Any]:
        from numcodecs import Blosc

        comp = Blosc(cname="zstd", clevel=self.config.compression_level, shuffle=Blosc.BITSHUFFLE)
        root = zarr.open_group(str(out), mode="w", zarr_format=2)
        data, meta = root.create_group("data"), root.create_group("meta")
        total = sum(len(e) for e in eps)
        arrays: dict[str, Any] = {}
        streams = image_streams(eps[0], depth=self.config.depth)

        def array(name: str, shape: tuple, dtype: Any, chunks: tuple) -> Any:
            if name not in arrays:  # a camera's name (from episode.json) is part of it: it stays inside `out`
                inside(out, f"data/{name}", source=eps[0].path / "episode.json", field=f"array {name!r}")
                arrays[name] = data.create_array(name, shape=(total, *shape), chunks=(chunks[0], *shape[:len(shape)])
                                                 if len(chunks) == 1 else chunks, dtype=dtype, compressor=comp)
            return arrays[name]

        pos, ends, done = 0, [], 0
        for ep in eps:
            n = len(ep)
            cols = lowdim(ep)
            t = cols.pop("t")
            cols["timestamp"] = t - t[0]
            for field, x in cols.items():
                name = _name(field)
                a = array(name, x.shape[1:], x.dtype, (min(total, 4096),))
                a[pos:pos + n] = x
            for cam, kind in streams:
                s = ep.stream(cam, kind)
                shape = (s["height"], s["width"], 3) if kind == "rgb" else (s["height"], s["width"])
                a = array(f"{cam}_{kind}", shape, np.uint8 if kind == "rgb" else np.uint16, (1, *shape))
                batch, start = [], pos
                for frame in ep.step_frames(cam, kind):
                    batch.append(frame)
                    if len(batch) == 64:
                        a[start:start + 64] = np.stack(batch)
                        start, batch = start + 64, []
                        if progress:  # also where export_dataset checks free space
                            progress(done + start - pos, total, f"episode {ep.index}: {cam} {kind}")
                if batch:
                    a[start:start + len(batch)] = np.stack(batch)
            pos += n
            ends.append(pos)
            done += n
            if progress:
                progress(done, total, f"episode {ep.index}")
        for field in lowdim(eps[0]):  # one name per element: the drivers' joints, `gripper`, the objects' `cube.x`
            if field != "t":
                a = arrays[_name(field)]
                a.attrs["names"] = element_names(eps, field, int(np.prod(a.shape[1:])))
        meta.create_array("episode_ends", shape=(len(ends),), dtype=np.int64, chunks=(max(len(ends), 1),))[:] = ends
        root.attrs["rio"] = {"fps": fps, "robot_type": robot_type(eps), "episodes": [rio_attrs(e) for e in eps],
                             "fields": {_name(f): f for f in lowdim(eps[0]) if f != "t"}}
        return {"episodes": len(eps), "steps": total, "arrays": sorted(arrays), "path": str(out)}

    def import_(self, src: Path, out: Path, *, progress: Progress | None = None) -> dict[str, Any]:
        zarr = _zarr()
        root = zarr.open_group(str(src), mode="r")
        rio = dict(root.attrs.get("rio", {}))
        fps = float(rio.get("fps") or 10.0)  # Diffusion Policy's real-robot data is 10 Hz
        fields = rio.get("fields") or {"state": "proprio", "action": "action"}
        ends = np.asarray(root["meta/episode_ends"][:])
        data = root["data"]
        names = list(data.array_keys())
        cams = [(n.rsplit("_", 1)[0], n.rsplit("_", 1)[1]) for n in names if n.endswith(("_rgb", "_depth"))]
        eps_meta = rio.get("episodes", [])
        start, total = 0, int(ends[-1]) if len(ends) else 0
        with open_recorder(Path(out), fps, eps_meta[0] if eps_meta else {}) as rec:
            for k, end in enumerate(ends):
                end = int(end)
                low = {fields.get(n, n): np.asarray(data[n][start:end]) for n in names
                       if n in fields or (n not in ("timestamp",) and not n.endswith(("_rgb", "_depth")))}
                m = eps_meta[k] if k < len(eps_meta) else {}
                units = {s["camera"]: s.get("depth_unit_m") or 0.001 for s in m.get("streams", {}).values()}
                images = {(c, kind): _rows(data[f"{c}_{kind}"], start, end) for c, kind in cams}
                t = np.asarray(data["timestamp"][start:end]) if "timestamp" in names else None
                env_names = data[ENVIRONMENT_STATE].attrs.get("names") if ENVIRONMENT_STATE in names else None
                if ENVIRONMENT_STATE in low:
                    name_environment_state(rec, m, low[ENVIRONMENT_STATE].reshape(end - start, -1).shape[1],
                                           env_names)
                for step in episode_steps(low, images, fps, m.get("instruction"), m.get("observation_class"),
                                          units, t, rio_meta=m, env_names=env_names):
                    rec.add(step)
                rec.keep({"imported_from": str(src)})
                start = end
                if progress:
                    progress(end, total, f"episode {k}")
        return {"episodes": len(ends), "steps": total, "path": str(out)}


ZarrConfig = ZarrFormat.Config


def _rows(array: Any, start: int, end: int, batch: int = 64):
    """Frames start..end of a (N, ...) zarr array, read a batch of chunks at a time."""
    for a in range(start, end, batch):
        yield from np.asarray(array[a:min(a + batch, end)])
