"""LeRobotDataset v3.0 on disk, as lerobot 0.4.x reads it (learned from its `datasets/utils.py`
and `lerobot_dataset.py`; no code taken from it):

    meta/info.json                      codebase_version "v3.0", fps, features, totals, path templates
    meta/stats.json                     per feature: min max mean std count q01 q10 q50 q90 q99
    meta/tasks.parquet                  pandas frame: index = task string, column task_index
    meta/episodes/chunk-000/file-000.parquet   one row per episode: length, tasks, where its rows
                                        (dataset_from_index/to_index, data/chunk_index, file_index)
                                        and video segments (videos/<key>/from_timestamp, ...) live
    data/chunk-000/file-000.parquet     one row per frame; fixed-size float32 lists per vector feature
    videos/<key>/chunk-000/file-000.mp4 every episode of a camera, one after another

Frame k of an episode has timestamp k/fps exactly, and lives in its camera's mp4 at
from_timestamp + k/fps: lerobot checks both against a 1e-4 s tolerance when it loads a frame.
"""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

CODEBASE_VERSION = "v3.0"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"
EPISODES_PATH = "meta/episodes/" + CHUNK_FILE + ".parquet"
INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
TASKS_PATH = "meta/tasks.parquet"
QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)

INDEX_FEATURES = {
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}


def quantile_key(q: float) -> str:
    return f"q{round(q * 100):02d}"


def info_json(fps: int, features: dict, robot_type: str | None, total_episodes: int, total_frames: int,
              total_tasks: int, chunks_size: int, data_mb: int, video_mb: int) -> dict:
    return {
        "codebase_version": CODEBASE_VERSION, "robot_type": robot_type, "total_episodes": total_episodes,
        "total_frames": total_frames, "total_tasks": total_tasks, "chunks_size": chunks_size,
        "data_files_size_in_mb": data_mb, "video_files_size_in_mb": video_mb, "fps": fps,
        "splits": {"train": f"0:{total_episodes}"}, "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if any(f["dtype"] == "video" for f in features.values()) else None,
        "features": features,
    }


def write_json(path: Path, obj: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(obj, indent=4, ensure_ascii=False))


def write_tasks(path: Path, tasks: list[str]) -> None:
    """tasks.parquet exactly as pandas would write a frame indexed by task (lerobot reads it with
    pandas and looks tasks up by index), without needing pandas here."""
    table = pa.table({"task_index": pa.array(range(len(tasks)), pa.int64()), "task": pa.array(tasks, pa.string())})
    pandas_meta = {
        "index_columns": ["task"],
        "column_indexes": [{"name": None, "field_name": None, "pandas_type": "unicode", "numpy_type": "object",
                            "metadata": {"encoding": "UTF-8"}}],
        "columns": [
            {"name": "task_index", "field_name": "task_index", "pandas_type": "int64", "numpy_type": "int64",
             "metadata": None},
            {"name": "task", "field_name": "task", "pandas_type": "unicode", "numpy_type": "object",
             "metadata": None},
        ],
        "attributes": {}, "creator": {"library": "rio-datasets", "version": "0.1.0"}, "pandas_version": "2.2.0",
    }
    table = table.replace_schema_metadata({b"pandas": json.dumps(pandas_meta).encode()})
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path)


def read_tasks(path: Path) -> list[str]:
    t = pq.read_table(path)
    names = [n for n in t.column_names if n != "task_index"]
    order = t.column("task_index").to_pylist()
    texts = t.column(names[0]).to_pylist()
    out = [""] * len(order)
    for i, s in zip(order, texts, strict=False):
        out[i] = s
    return out
