"""LeRobotDataset v3 export and import (layout: see `lerobot_paths`).

Export re-encodes each camera at the dataset's rate with exactly one video frame per step (the
frame that step saw), so video and parquet timestamps agree to the microsecond however the
cameras' real rates drifted during recording: lerobot's tolerance checks cannot fail.

Frame t holds `observation.state` (the proprio), the other observation fields, the environment state
(`observation.environment_state`, float32, one name per element: `cube.x`, ..., `cube.qz`, ...), each
force/torque sensor's wrench (`observation.wrench_<sensor>`, float32, fx fy fz N, tx ty tz N m) all read at
step t, and `action`: the command issued after that observation (`common`: native actions shifted by one).
"""

from __future__ import annotations

import itertools
import json
import math
from fractions import Fraction
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from pydantic import Field

from rio.config import Config
from rio.machine.confine import inside
from rio.recording import Dataset
from rio.recording.format import DatasetFormat, Progress
from rio.recording.video import quiet_svt, scheduling_kept

from . import lerobot_paths as LL
from .common import (
    ENVIRONMENT_STATE,
    WRENCH_PREFIX,
    ExportError,
    check_same_layout,
    common_fps,
    element_names,
    empty_task_episodes,
    environment_state,
    image_streams,
    lowdim,
    rio_attrs,
    robot_type,
    select,
)
from .native_writer import episode_steps, name_environment_state, open_recorder


class _VideoFile:
    """One mp4 that episodes of one camera are appended to (pts = frame number at the dataset rate)."""

    def __init__(self, path: Path, fps: int, height: int, width: int, opts: LeRobotConfig):
        import av

        path.parent.mkdir(parents=True, exist_ok=True)
        self.path, self.frames, self.bytes = path, 0, 0
        self.container = av.open(str(path), "w", format="mp4")
        if opts.codec == "av1":
            quiet_svt()
            codec, o = "libsvtav1", {"crf": str(opts.crf), "preset": opts.preset or "10", "g": str(opts.gop)}
        else:
            codec, o = "libx264", {"crf": str(opts.crf), "preset": opts.preset or "veryfast", "g": str(opts.gop),
                                   "bf": "0"}
        self.stream = self.container.add_stream(codec, rate=Fraction(fps), options=o)
        self.stream.pix_fmt, self.stream.height, self.stream.width = "yuv420p", height, width

    def add(self, rgb: np.ndarray) -> None:
        import av

        vf = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
        vf.pts = self.frames
        self.frames += 1
        with scheduling_kept():  # SVT-AV1 as root leaves its caller at SCHED_FIFO 99
            packets = self.stream.encode(vf)
        for p in packets:
            self.bytes += p.size
            self.container.mux(p)

    def close(self) -> None:
        with scheduling_kept():
            packets = self.stream.encode()
        for p in packets:
            self.container.mux(p)
        self.container.close()


class _Stats:
    """min/max/mean/std/count/quantiles as lerobot's stats.json holds them."""

    @staticmethod
    def numeric(x: np.ndarray) -> dict[str, list]:
        x = x.reshape(len(x), -1).astype(np.float64)
        out = {"min": x.min(0), "max": x.max(0), "mean": x.mean(0), "std": x.std(0), "count": np.array([len(x)])}
        for q in LL.QUANTILES:
            out[LL.quantile_key(q)] = np.quantile(x, q, axis=0)
        return {k: v.tolist() for k, v in out.items()}

    @staticmethod
    def image(pixels: np.ndarray, count: int) -> dict[str, list]:
        """`pixels`: (N, 3) sampled values in [0, 1]; stats shaped (3, 1, 1) per channel."""
        def c(v: np.ndarray) -> list:
            return v.reshape(3, 1, 1).tolist()
        out = {"min": c(pixels.min(0)), "max": c(pixels.max(0)), "mean": c(pixels.mean(0)),
               "std": c(pixels.std(0)), "count": [count]}
        for q in LL.QUANTILES:
            out[LL.quantile_key(q)] = c(np.quantile(pixels, q, axis=0))
        return out


def _merge(ep: Any) -> dict[str, Any] | None:
    """What `rio datasets merge` recorded about an episode (None: not a merged episode)."""
    m = ep.meta.get("merge")
    return m if isinstance(m, dict) else None


def _tag(ep: Any) -> str:
    m = _merge(ep)
    if m is not None and isinstance(m.get("embodiment"), dict) and m["embodiment"].get("tag"):
        return str(m["embodiment"]["tag"])
    return str(ep.meta.get("embodiment") or ep.meta.get("station") or "unknown")


def _mask(ep: Any, col: str, size: int) -> np.ndarray:
    """A merged episode's mask of a lowdim column (flat, true where real); all true otherwise."""
    m = _merge(ep)
    f = (m or {}).get("fields", {}).get("action" if col == "action" else f"obs.{col}")
    return np.ones(size, bool) if not isinstance(f, dict) else np.asarray(f["mask"], bool).reshape(-1)


#: The LeRobot feature of the environment state.
ENVIRONMENT_FEATURE = f"observation.{ENVIRONMENT_STATE}"


class LeRobotFormat(DatasetFormat):
    name = "lerobot"
    can_import = True

    class Config(Config):
        codec: Literal["av1", "h264"] = Field("av1", description="video codec of the exported mp4 files")
        crf: int = Field(30, ge=0, le=63)
        gop: int = Field(2, ge=1, description="keyframe interval in frames (lerobot uses 2: fast random access)")
        preset: str | None = Field(None, description="encoder preset (default: 10 for av1, veryfast for h264)")
        robot_type: str | None = Field(None, description="info.json robot_type (default: the station's arm driver, "
                                                          "as recorded)")
        task: str | None = Field(None, description="the task of frames recorded without an instruction "
                                                    "(otherwise an empty task, and a warning)")
        extra_observations: bool = Field(True, description="also export observation.<field> beside observation.state")
        data_files_size_in_mb: int = Field(100, gt=0)
        video_files_size_in_mb: int = Field(200, gt=0)
        chunks_size: int = Field(1000, gt=0)

    # -- export -------------------------------------------------------------------------------------
    def _features(self, eps: list[Any]) -> tuple[dict, dict[str, str]]:
        """(lerobot features, {lerobot key: rio column}) for the numeric columns, each named per element
        (`common.element_names`: the drivers' joint names, `gripper`, the objects' `cube.x` ...)."""
        o = self.config
        ep = eps[0]
        cols = lowdim(ep)
        mapping = {"observation.state": "proprio", "action": "action"}
        env = environment_state(ep)
        if env is not None:  # the environment state is a standard LeRobot feature: exported either way
            mapping[ENVIRONMENT_FEATURE] = ENVIRONMENT_STATE
        mapping.update({f"observation.{k}": k for k in cols if k.startswith(WRENCH_PREFIX)})  # either way too
        if o.extra_observations:
            mapping.update({f"observation.{k}": k for k in cols
                            if k not in ("proprio", "action", "t", ENVIRONMENT_STATE)})
        feats = {}
        for key, col in mapping.items():
            if col not in cols:
                raise ExportError(f"episode {ep.index} has no '{col}' column; "
                                  "LeRobot needs observation.state and action")
            n = int(np.prod(cols[col].shape[1:])) if cols[col].ndim > 1 else 1
            feats[key] = {"dtype": "float32", "shape": [n], "names": element_names(eps, col, n)}
        return feats, mapping

    def export(self, dataset: Dataset, out: Path, *, episodes: list[int] | None = None,
               progress: Progress | None = None) -> dict[str, Any]:
        o = self.config
        out = Path(out)
        if out.exists() and any(out.iterdir()):  # export_dataset refuses it first, naming --overwrite
            raise ExportError(f"{out} exists and is not empty; --overwrite replaces it")
        eps = select(dataset, episodes)
        check_same_layout(eps, absent_ok=True)
        # a merged dataset (`rio datasets merge`): masks as columns, embodiments, cameras some episodes lack
        merged = any(_merge(e) is not None for e in eps)
        tags = list(dict.fromkeys(_tag(e) for e in eps)) if merged else []
        fps_f = common_fps(eps)
        fps = round(fps_f)
        if abs(fps - fps_f) > 1e-6:
            raise ExportError(f"LeRobotDataset needs an integer fps; this dataset was recorded at {fps_f:g} Hz")
        features, mapping = self._features(eps)
        if merged:
            for key in mapping:
                features[f"mask.{key}"] = {"dtype": "bool", "shape": features[key]["shape"],
                                           "names": features[key]["names"]}
        cams = sorted({c for e in eps for c, _ in image_streams(e, depth=False)})
        if merged:
            features.update({f"mask.observation.images.{c}": {"dtype": "bool", "shape": [1], "names": None}
                             for c in cams})
            features["embodiment_index"] = {"dtype": "int64", "shape": [1], "names": None}
        for cam in cams:
            sizes = {(e.stream(cam)["height"], e.stream(cam)["width"]) for e in eps if f"{cam}.rgb" in e.streams}
            if len(sizes) > 1:
                raise ExportError(f"camera '{cam}' has different sizes in different episodes {sorted(sizes)}; "
                                  "LeRobotDataset needs one size per camera: export them separately")
            h, w = sizes.pop()
            h, w = h + h % 2, w + w % 2
            features[f"observation.images.{cam}"] = {
                "dtype": "video", "shape": [h, w, 3], "names": ["height", "width", "channels"],
                "info": {"video.height": h, "video.width": w, "video.codec": "av1" if o.codec == "av1" else "h264",
                         "video.pix_fmt": "yuv420p", "video.is_depth_map": False, "video.fps": fps,
                         "video.channels": 3, "has_audio": False}}
        features.update(LL.INDEX_FEATURES)
        skipped = sorted({f"{c}.depth" for e in eps for c, k in image_streams(e) if k == "depth"})
        total = sum(len(e) for e in eps)
        tasks: list[str] = []
        ep_rows: list[dict[str, Any]] = []
        numeric: dict[str, list[np.ndarray]] = {k: [] for k in features if features[k]["dtype"] != "video"}
        pixels: dict[str, list[np.ndarray]] = {c: [] for c in cams}
        data_writer: pq.ParquetWriter | None = None
        data_pos, data_bytes = (0, 0), 0
        videos: dict[str, _VideoFile] = {}
        video_pos: dict[str, tuple[int, int]] = {c: (0, 0) for c in cams}
        done = g_index = 0

        def next_pos(pos: tuple[int, int]) -> tuple[int, int]:
            return (pos[0] + 1, 0) if pos[1] + 1 >= o.chunks_size else (pos[0], pos[1] + 1)

        try:
            for e_i, ep in enumerate(eps):
                n = len(ep)
                cols = lowdim(ep)
                instr = [s or o.task or "" for s in ep.instructions()]
                mark = {k: len(v) for k, v in numeric.items()}
                px_mark = {c: len(v) for c, v in pixels.items()}
                for s in instr:
                    if s not in tasks:
                        tasks.append(s)
                columns: dict[str, pa.Array] = {}
                for key, col in mapping.items():
                    x = cols[col].reshape(n, -1).astype(np.float32)
                    numeric[key].append(x)
                    size = x.shape[1]
                    # shape [1] is a plain float column for lerobot (datasets.Value), longer ones fixed-size lists
                    columns[key] = (pa.array(x[:, 0], pa.float32()) if size == 1 else
                                    pa.FixedSizeListArray.from_arrays(pa.array(x.reshape(-1), pa.float32()), size))
                if merged:  # per-frame copies of the episode's masks, then which cameras are real, then its tag
                    masks = {f"mask.{key}": np.broadcast_to(_mask(ep, col, features[key]["shape"][0]),
                                                            (n, features[key]["shape"][0]))
                             for key, col in mapping.items()}
                    masks.update({f"mask.observation.images.{c}": np.full((n, 1), f"{c}.rgb" in ep.streams)
                                  for c in cams})
                    for key, m in masks.items():
                        numeric[key].append(m)
                        columns[key] = (pa.array(m[:, 0], pa.bool_()) if m.shape[1] == 1 else
                                        pa.FixedSizeListArray.from_arrays(pa.array(m.reshape(-1), pa.bool_()),
                                                                          m.shape[1]))
                    columns["embodiment_index"] = pa.array(np.full(n, tags.index(_tag(ep)), np.int64))
                    numeric["embodiment_index"].append(np.full((n, 1), tags.index(_tag(ep)), np.int64))
                index_cols = {
                    "timestamp": (np.arange(n) / fps).astype(np.float32), "frame_index": np.arange(n, dtype=np.int64),
                    "episode_index": np.full(n, e_i, np.int64),
                    "index": np.arange(g_index, g_index + n, dtype=np.int64),
                    "task_index": np.array([tasks.index(s) for s in instr], np.int64)}
                for k, v in index_cols.items():
                    columns[k] = pa.array(v)
                    numeric[k].append(v.reshape(n, 1))
                table = pa.table(columns)
                if data_writer is not None and data_bytes >= o.data_files_size_in_mb * 1e6:
                    data_writer.close()
                    data_writer, data_pos, data_bytes = None, next_pos(data_pos), 0
                if data_writer is None:
                    path = out / LL.DATA_PATH.format(chunk_index=data_pos[0], file_index=data_pos[1])
                    path.parent.mkdir(parents=True, exist_ok=True)
                    data_writer = pq.ParquetWriter(path, table.schema, compression="snappy")
                data_writer.write_table(table)
                data_bytes += table.nbytes
                row: dict[str, Any] = {
                    "episode_index": e_i, "tasks": list(dict.fromkeys(instr)), "length": n,
                    "data/chunk_index": data_pos[0], "data/file_index": data_pos[1],
                    "dataset_from_index": g_index, "dataset_to_index": g_index + n}
                for cam in cams:
                    key = f"observation.images.{cam}"
                    vf = videos.get(cam)
                    if vf is not None and vf.bytes >= o.video_files_size_in_mb * 1e6:
                        vf.close()
                        vf, video_pos[cam] = None, next_pos(video_pos[cam])
                    if vf is None:
                        h, w = features[key]["shape"][:2]
                        where = LL.VIDEO_PATH.format(video_key=key, chunk_index=video_pos[cam][0],
                                                     file_index=video_pos[cam][1])
                        # the camera's name came from episode.json: its video stays inside the export
                        vf = videos[cam] = _VideoFile(inside(out, where, source=ep.path / "episode.json",
                                                             field=f"camera {cam!r}"), fps, h, w, o)
                    start = vf.frames
                    step_every = max(1, n // 30)
                    real = f"{cam}.rgb" in ep.streams
                    # a camera a merged episode lacks: black frames (masked), so every video stays aligned
                    frames = ep.step_frames(cam, "rgb") if real else itertools.repeat(
                        np.zeros((*features[key]["shape"][:2], 3), np.uint8), n)
                    for k, frame in enumerate(frames):
                        if frame.shape[0] % 2 or frame.shape[1] % 2:
                            pad = ((0, frame.shape[0] % 2), (0, frame.shape[1] % 2), (0, 0))
                            frame = np.pad(frame, pad, mode="edge")
                        vf.add(frame)
                        if real and k % step_every == 0:
                            pixels[cam].append(frame[::8, ::8].reshape(-1, 3))
                        if progress and k % 50 == 0:
                            progress(done + k, total, f"episode {ep.index}: {cam}")
                    row.update({f"videos/{key}/chunk_index": video_pos[cam][0],
                                f"videos/{key}/file_index": video_pos[cam][1],
                                f"videos/{key}/from_timestamp": start / fps,
                                f"videos/{key}/to_timestamp": vf.frames / fps})
                row["meta/episodes/chunk_index"], row["meta/episodes/file_index"] = 0, 0
                # this episode's stats, as lerobot writes them beside it (`stats/<feature>/<min|max|...>`)
                ep_stats = {k: _Stats.numeric(np.concatenate(v[mark[k]:])) for k, v in numeric.items()}
                for cam in cams:
                    if len(pixels[cam]) > px_mark[cam]:
                        px = np.concatenate(pixels[cam][px_mark[cam]:]).astype(np.float64) / 255.0
                        ep_stats[f"observation.images.{cam}"] = _Stats.image(px, n)
                row.update({f"stats/{k}/{stat}": v for k, st in ep_stats.items() for stat, v in st.items()})
                ep_rows.append(row)
                g_index += n
                done += n
                if progress:
                    progress(done, total, f"episode {ep.index}")
        finally:
            if data_writer is not None:
                data_writer.close()
            for vf in videos.values():
                vf.close()
        keys = list(dict.fromkeys(k for r in ep_rows for k in r))  # a camera a merged episode lacks: no stats
        ep_table = pa.Table.from_pylist([{k: r.get(k) for k in keys} for r in ep_rows])
        path = out / LL.EPISODES_PATH.format(chunk_index=0, file_index=0)
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(ep_table, path)
        LL.write_tasks(out / LL.TASKS_PATH, tasks)
        stats = {k: _Stats.numeric(np.concatenate(v)) for k, v in numeric.items()}
        for cam in cams:
            px = np.concatenate(pixels[cam]).astype(np.float64) / 255.0
            stats[f"observation.images.{cam}"] = _Stats.image(px, total)
        LL.write_json(out / LL.STATS_PATH, stats)
        # the station's arm driver as recorded (so101.follower); datasets recorded before it was: the embodiment
        robot = o.robot_type or robot_type(eps)
        if robot is None:
            robot = eps[0].meta.get("embodiment") or eps[0].meta.get("station")
            if merged and len(tags) > 1:
                robot = "+".join(sorted({t.partition("@")[0] for t in tags}))  # e.g. bimanual+single_arm
        LL.write_json(out / LL.INFO_PATH, LL.info_json(fps, features, robot, len(eps), total, len(tasks),
                                                        o.chunks_size, o.data_files_size_in_mb,
                                                        o.video_files_size_in_mb))
        # what a RIO import needs to restore the morphology (lerobot ignores this file)
        rio: dict[str, Any] = {"mapping": mapping, "episodes": [rio_attrs(e) for e in eps]}
        if merged:  # embodiment_index -> tag; each episode's merge facts (source, tag, masks, absent cameras)
            rio["embodiments"] = tags
            for entry, e in zip(rio["episodes"], eps, strict=True):
                entry["merge"] = _merge(e)
        LL.write_json(out / "meta" / "rio.json", rio)
        result: dict[str, Any] = {"episodes": len(eps), "frames": total, "cameras": cams, "fps": fps,
                                  "skipped_streams": skipped, "robot_type": robot, "path": str(out)}
        if not o.task and (untasked := empty_task_episodes(eps)):
            which = ", ".join(map(str, untasked[:5])) + (", ..." if len(untasked) > 5 else "")
            result["warnings"] = [f"{len(untasked)} episode(s) ({which}) have frames recorded without an instruction: "
                                  "their LeRobot "
                                  "task is empty (a language-conditioned policy learns nothing from it); record "
                                  "with --instruction, or export with -o task=\"...\""]
        if merged:
            result["embodiments"] = tags
        return result

    # -- import -------------------------------------------------------------------------------------
    def import_(self, src: Path, out: Path, *, progress: Progress | None = None) -> dict[str, Any]:
        src = Path(src)
        info = json.loads((src / LL.INFO_PATH).read_text())
        if not str(info.get("codebase_version", "")).startswith("v3"):
            raise ExportError(f"{src}: codebase_version {info.get('codebase_version')!r}; only v3.x is supported")
        fps = float(info["fps"])
        rio = json.loads((src / "meta" / "rio.json").read_text()) if (src / "meta" / "rio.json").exists() else {}
        mapping = rio.get("mapping") or {"observation.state": "proprio", "action": "action"}
        env_feature = info["features"].get(ENVIRONMENT_FEATURE)
        if env_feature is not None:  # a LeRobot dataset from elsewhere has one too
            mapping = {**mapping, ENVIRONMENT_FEATURE: ENVIRONMENT_STATE}
        rio_eps = rio.get("episodes", [])
        tasks = LL.read_tasks(src / LL.TASKS_PATH)
        ep_table = pa.concat_tables([pq.read_table(p) for p in sorted((src / "meta" / "episodes").glob("*/*.parquet"))])
        data = pa.concat_tables([pq.read_table(p) for p in sorted((src / "data").glob("*/*.parquet"))])
        video_keys = [k for k, f in info["features"].items() if f["dtype"] == "video"]
        rows = sorted(ep_table.to_pylist(), key=lambda r: r["episode_index"])
        total = sum(r["length"] for r in rows)
        done = 0
        with open_recorder(out, fps, rio_eps[0] if rio_eps else {"station": info.get("robot_type")}) as rec:
            for e_i, r in enumerate(rows):
                a, b = r["dataset_from_index"], r["dataset_to_index"]
                part = data.slice(a, b - a)
                low = {}
                for key, col in mapping.items():
                    if key in part.column_names:
                        x = np.asarray(part.column(key).to_pylist(), dtype=np.float32)
                        low[col] = x[:, 0] if info["features"][key]["shape"] == [1] and x.ndim == 2 else x
                images = {}
                for key in video_keys:
                    cam = key.split(".")[-1]
                    where = info["video_path"].format(video_key=key, chunk_index=r[f"videos/{key}/chunk_index"],
                                                      file_index=r[f"videos/{key}/file_index"])
                    path = inside(src, where, source=src / LL.INFO_PATH, field=f"video_path of '{key}'")
                    images[(cam, "rgb")] = _segment(path, r[f"videos/{key}/from_timestamp"], b - a, fps)
                meta = rio_eps[e_i] if e_i < len(rio_eps) else {}
                task_idx = part.column("task_index").to_pylist()
                instruction = tasks[task_idx[0]] if task_idx else None
                env_names = (env_feature or {}).get("names")
                if ENVIRONMENT_STATE in low:
                    env = low[ENVIRONMENT_STATE]
                    name_environment_state(rec, meta, env.reshape(len(env), -1).shape[1], env_names)
                for step in episode_steps(low, images, fps, instruction or None, meta.get("observation_class"),
                                          rio_meta=meta, env_names=env_names):
                    step.instruction = tasks[task_idx[step.timestep]] or None
                    rec.add(step)
                rec.keep({"imported_from": str(src), "lerobot_episode_index": r["episode_index"]})
                done += b - a
                if progress:
                    progress(done, total, f"episode {e_i}")
        return {"episodes": len(rows), "frames": total, "path": str(out)}


LeRobotConfig = LeRobotFormat.Config


def _segment(path: Path, from_ts: float, n: int, fps: float):
    """The n frames of one episode inside a concatenated mp4, starting at from_ts."""
    import av

    with av.open(str(path)) as c:
        s = c.streams.video[0]
        c.seek(max(int(math.floor(from_ts / s.time_base)) - 1, 0), stream=s, backward=True, any_frame=False)
        got = 0
        for frame in c.decode(s):
            t = float(frame.pts * s.time_base)
            if t < from_ts - 0.5 / fps:
                continue
            yield frame.to_ndarray(format="rgb24")
            got += 1
            if got == n:
                return
    if got < n:
        raise ExportError(f"{path}: expected {n} frames from t={from_ts:.3f} s, found {got}")
