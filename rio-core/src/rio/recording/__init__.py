"""Recording and datasets (docs: docs/record.md, docs/export.md, docs/datasets.md).

- `Recorder`: Steps of a control loop into the native, crash-safe layout (`paths` documents it);
  camera streams are video-encoded by a separate process while recording.
- `Dataset` / `Episode`: read it back (columns, decoded frames, rebuilt `Step`s); damaged files are
  refused (`DamagedEpisode`) unless `allow_damaged=True`.
- `repair_dataset`: turn what a crash left into finished episodes, rebuild the index.
- `export_dataset`: export through a format, leaving no partial output behind when it fails.
- `merge_datasets`: datasets of different morphologies into one padded dataset (masks, embodiment tags).
- `replay.EpisodeReplay`: the controller that plays an episode's actions back (`rio.workflows.replay`).
- `DatasetFormat` / `get_format`: export and import through plugins' `rio_dataset_formats` hook.
"""

from rio.recording.dataset import DamagedEpisode, DamagedEpisodeWarning, Dataset, DatasetError, Episode
from rio.recording.recorder import DiskFull, Recorder, RecordingError, station_depth
from rio.recording.video import VideoOptions

__all__ = ["Recorder", "RecordingError", "DiskFull", "station_depth", "Dataset", "DatasetError", "DamagedEpisode",
           "DamagedEpisodeWarning", "Episode", "VideoOptions", "repair_dataset", "DatasetFormat",
           "get_format", "export_dataset", "merge_datasets", "MergeError"]


def __getattr__(name: str):
    if name == "repair_dataset":
        from rio.recording.repair import repair_dataset

        return repair_dataset
    if name in ("merge_datasets", "MergeError"):
        from rio.recording import merge as M

        return getattr(M, name)
    if name in ("DatasetFormat", "get_format", "export_dataset"):
        from rio.recording import format as F

        return getattr(F, name)
    raise AttributeError(name)
