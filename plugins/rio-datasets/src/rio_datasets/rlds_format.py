"""RLDS export (Open X-Embodiment): one RLDS episode per RIO episode, written with TensorFlow Datasets' own
writer (`tfds.core.SequentialWriter`), so `tfds.builder_from_directory(OUT/<name>/1.0.0)` (or
`tfds.load(name, data_dir=OUT)`) reads it as it reads the OXE datasets:

    OUT/<name>/1.0.0/
      dataset_info.json, features.json    the feature spec (each element named in its `doc`)
      metadata.json                       robot_type, control_rate_hz, station, embodiment, element names
      <name>-train.tfrecord-0000N-of-...  the episodes

    episode
      steps: a Dataset of
        observation
          state               float32 (S,)   the proprio, read at this step
          <camera>_image      uint8 (H, W, 3) the frame this step saw (`main_camera`: `image`)
          environment_state   float32 (E,)   a simulator's object poses (when recorded)
          wrench              float32 (6,)   a force-torque reading, N and N m (when recorded)
        action                float32 (A,)   the command issued after this observation (as every export)
        reward                float32        1 at the last step of a successful episode, else 0
        discount              float32        1
        is_first, is_last     bool
        is_terminal           bool           the last step of a successful episode (the task is over)
        language_instruction  string         the instruction in force at this step (`task` when none)
      episode_metadata: file_path (the RIO episode directory), episode_index, station

An episode is successful when its recorded task says so (`metadata.task.success`, a simulated task's
verdict); a kept demonstration without a task verdict counts as one (the OXE datasets' convention for
demonstrations). Depth streams are not exported (listed under `skipped_streams`).

TensorFlow is an extra (`pip install 'rio-datasets[rlds]'`, ~1.7 GB): without it this format says so.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.config import Config
from rio.recording import Dataset, Episode
from rio.recording.format import DatasetFormat, Progress

from .common import (
    ENVIRONMENT_STATE,
    WRENCH_PREFIX,
    ExportError,
    check_same_layout,
    common_fps,
    element_names,
    empty_task_episodes,
    image_streams,
    lowdim,
    robot_type,
    select,
    wrenches,
)

#: What to install for this format.
EXTRA = "pip install 'rio-datasets[rlds]'"
VERSION = "1.0.0"


def _tfds() -> Any:
    """tensorflow_datasets (TensorFlow's C++ logging kept to errors unless the user set it)."""
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    try:
        import tensorflow_datasets as tfds
    except ImportError as e:
        raise ExportError(f"the rlds format needs TensorFlow Datasets ({e.name or e}): {EXTRA}") from None
    return tfds


def wrench_columns(ep: Episode) -> list[str]:
    """The step columns holding a force-torque reading: a field or sensor value named `wrench`, and each
    wrench-kind sensor's `force` and `torque` pair (`common.wrenches`), named `meta.sensors.<sensor>.wrench`
    here; `wrench_values` reads either."""
    named = [n for n in ep.schema.names if n.rsplit(".", 1)[-1] == "wrench"]
    pairs = [f"meta.sensors.{k[len(WRENCH_PREFIX):]}.wrench" for k in wrenches(ep)]
    return named + [p for p in pairs if p not in named]


def wrench_values(ep: Episode, col: str) -> np.ndarray:
    """(T, ...) of one of `wrench_columns(ep)`: the column itself, or a sensor's force and torque joined (6)."""
    if col in ep.schema.names:
        return ep.column(col)
    return wrenches(ep)[WRENCH_PREFIX + col.split(".")[-2]]


def dataset_name(root: Path) -> str:
    """A TFDS dataset name from the native dataset's folder (snake case, starting with a letter)."""
    name = re.sub(r"[^a-z0-9]+", "_", root.resolve().name.lower()).strip("_") or "rio"
    return name if name[0].isalpha() else f"rio_{name}"


def _success(ep: Episode) -> bool:
    task = (ep.meta.get("metadata") or {}).get("task")
    return bool(task.get("success", True)) if isinstance(task, dict) else True


class RldsFormat(DatasetFormat):
    name = "rlds"

    class Config(Config):
        name: str | None = Field(None, pattern=r"^[a-z][a-z0-9_]*$",
                                 description="TFDS dataset name (default: the dataset folder's, snake case)")
        image_encoding: Literal["jpeg", "png"] = Field("jpeg", description="how frames are stored (png: lossless)")
        main_camera: str | None = Field(None, description="the camera stored as observation/image (OXE's main "
                                                          "view); the others as <camera>_image")
        task: str | None = Field(None, description="the language_instruction of steps recorded without one")
        episodes_per_shard: int = Field(50, gt=0, description="episodes per TFRecord file")

    def _features(self, tfds: Any, eps: list[Episode], cams: list[str], sizes: dict[str, tuple[int, int]],
                  wrench: list[str]) -> tuple[Any, dict[str, list[str]]]:
        """(the episode FeaturesDict, {field: element names})."""
        ep, cols = eps[0], lowdim(eps[0])
        names = {"state": element_names(eps, "proprio", _width(cols["proprio"])),
                 "action": element_names(eps, "action", _width(cols["action"]))}
        obs: dict[str, Any] = {"state": _tensor(tfds, names["state"], "the proprio, read at this step")}
        for cam in cams:
            h, w = sizes[cam]
            obs[self._image_key(cam)] = tfds.features.Image(shape=(h, w, 3), dtype=np.uint8,
                                                            encoding_format=self.config.image_encoding,
                                                            doc=f"camera '{cam}': the frame this step saw")
        if ENVIRONMENT_STATE in cols:
            names[ENVIRONMENT_STATE] = element_names(eps, ENVIRONMENT_STATE, _width(cols[ENVIRONMENT_STATE]))
            obs[ENVIRONMENT_STATE] = _tensor(tfds, names[ENVIRONMENT_STATE], "object poses: m, quaternion wxyz")
        for col in wrench:
            key = _wrench_key(col, wrench)
            width = _width(wrench_values(ep, col))
            axes = ("fx", "fy", "fz", "tx", "ty", "tz") if width == 6 else tuple(map(str, range(width)))
            names[key] = [f"{key}.{a}" for a in axes]
            obs[key] = _tensor(tfds, names[key], f"force-torque reading ({col}): N, N m")
        scalar = tfds.features.Scalar
        steps = {
            "observation": tfds.features.FeaturesDict(obs),
            "action": _tensor(tfds, names["action"], "the command issued after this step's observation"),
            "reward": scalar(dtype=np.float32, doc="1 at the last step of a successful episode"),
            "discount": scalar(dtype=np.float32, doc="1"),
            "is_first": scalar(dtype=np.bool_), "is_last": scalar(dtype=np.bool_),
            "is_terminal": scalar(dtype=np.bool_, doc="the last step of a successful episode"),
            "language_instruction": tfds.features.Text(doc="the instruction in force at this step"),
        }
        features = tfds.features.FeaturesDict({
            "steps": tfds.features.Dataset(steps),
            "episode_metadata": tfds.features.FeaturesDict({
                "file_path": tfds.features.Text(doc="the RIO episode directory"),
                "episode_index": scalar(dtype=np.int64, doc="the RIO episode's index"),
                "station": tfds.features.Text()}),
        })
        return features, names

    def _image_key(self, cam: str) -> str:
        return "image" if cam == self.config.main_camera else f"{cam}_image"

    def export(self, dataset: Dataset, out: Path, *, episodes: list[int] | None = None,
               progress: Progress | None = None) -> dict[str, Any]:
        o = self.config
        out = Path(out)
        tfds = _tfds()
        eps = select(dataset, episodes)
        check_same_layout(eps)
        fps = common_fps(eps)
        if "action" not in eps[0].schema.names or "obs.proprio" not in eps[0].schema.names:
            raise ExportError(f"episode {eps[0].index} has no action or proprio column; RLDS steps need both")
        cams = sorted({c for c, _ in image_streams(eps[0], depth=False)})
        if o.main_camera is not None and o.main_camera not in cams:
            raise ExportError(f"main_camera '{o.main_camera}': the dataset has no such camera (cameras: "
                              f"{', '.join(cams) or 'none'})")
        sizes = {c: (eps[0].stream(c)["height"], eps[0].stream(c)["width"]) for c in cams}
        for e in eps[1:]:
            for c in cams:
                if (e.stream(c)["height"], e.stream(c)["width"]) != sizes[c]:
                    raise ExportError(f"camera '{c}' has different sizes in episodes {eps[0].index} and {e.index}; "
                                      "RLDS needs one size per camera: export them separately")
        wrench = wrench_columns(eps[0])
        features, names = self._features(tfds, eps, cams, sizes, wrench)
        name = o.name or dataset_name(dataset.root)
        robot = robot_type(eps)
        metadata = {"robot_type": robot, "control_rate_hz": fps, "station": eps[0].meta.get("station"),
                    "embodiment": eps[0].meta.get("embodiment"), "names": names,
                    "action": "action[t] is the command issued after observation[t]",
                    "source": str(dataset.root), "rio_episodes": [e.index for e in eps]}
        info = tfds.core.DatasetInfo(
            builder=tfds.core.DatasetIdentity(name=name, data_dir=str(out / name / VERSION), module_name="",
                                              version=VERSION),
            description=f"Recorded with RIO on station '{eps[0].meta.get('station')}'"
                        f"{f' ({robot})' if robot else ''} at {fps:g} Hz.",
            features=features, metadata=tfds.core.MetadataDict(metadata))
        total, done = sum(len(e) for e in eps), 0
        skipped = sorted({f"{c}.depth" for e in eps for c, k in image_streams(e) if k == "depth"})
        (out / name / VERSION).mkdir(parents=True, exist_ok=True)
        writer = tfds.core.SequentialWriter(ds_info=info, max_examples_per_shard=o.episodes_per_shard)
        writer.initialize_splits(["train"])
        for ep in eps:
            writer.add_examples({"train": [self._episode(ep, cams, wrench)]})
            done += len(ep)
            if progress:
                progress(done, total, f"episode {ep.index}")
        writer.close_splits(["train"])
        result: dict[str, Any] = {"episodes": len(eps), "steps": total, "cameras": cams, "fps": fps,
                                  "skipped_streams": skipped, "robot_type": robot, "name": name,
                                  "path": str(out / name / VERSION)}
        if not o.task and (untasked := empty_task_episodes(eps)):
            which = ", ".join(map(str, untasked[:5])) + (", ..." if len(untasked) > 5 else "")
            result["warnings"] = [f"{len(untasked)} episode(s) ({which}) have steps recorded without an instruction: "
                                  "their language_instruction is empty; record with --instruction, or export "
                                  "with -o task=\"...\""]
        return result

    def _episode(self, ep: Episode, cams: list[str], wrench: list[str]) -> dict[str, Any]:
        """One RLDS episode: its steps as lists of per-step values (what the Dataset feature encodes)."""
        n = len(ep)
        cols = lowdim(ep)
        obs: dict[str, Any] = {"state": cols["proprio"].reshape(n, -1).astype(np.float32)}
        for cam in cams:
            obs[self._image_key(cam)] = np.stack(list(ep.step_frames(cam, "rgb")))
        if ENVIRONMENT_STATE in cols:
            obs[ENVIRONMENT_STATE] = cols[ENVIRONMENT_STATE].reshape(n, -1).astype(np.float32)
        for col in wrench:
            obs[_wrench_key(col, wrench)] = wrench_values(ep, col).reshape(n, -1).astype(np.float32)
        last = np.arange(n) == n - 1
        success = _success(ep)
        task = self.config.task or ""
        return {
            "steps": {
                "observation": obs,
                "action": cols["action"].reshape(n, -1).astype(np.float32),
                "reward": (last & success).astype(np.float32),
                "discount": np.ones(n, np.float32),
                "is_first": np.arange(n) == 0, "is_last": last, "is_terminal": last & success,
                "language_instruction": [s or task for s in ep.instructions()],
            },
            "episode_metadata": {"file_path": str(ep.path), "episode_index": ep.index,
                                 "station": str(ep.meta.get("station") or "")},
        }


def _width(x: np.ndarray) -> int:
    return int(np.prod(x.shape[1:])) if x.ndim > 1 else 1


def _tensor(tfds: Any, names: list[str], doc: str) -> Any:
    """A float32 vector feature whose doc names its elements (RLDS has no `names` field of its own)."""
    return tfds.features.Tensor(shape=(len(names),), dtype=np.float32, doc=f"{doc}; elements: {', '.join(names)}")


def _wrench_key(col: str, all_cols: list[str]) -> str:
    """`wrench` for the one force-torque column; `<sensor>_wrench` when there are several."""
    if len(all_cols) == 1:
        return "wrench"
    parts = col.split(".")
    return f"{parts[-2]}_wrench" if len(parts) > 1 else col
