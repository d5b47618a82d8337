"""The exporters and importers never write or read outside the directories they were given, whatever
names a dataset holds (`rio.machine.confine`): a camera's name becomes a file or array name in every
format, and a LeRobot dataset's `info.json` says where its videos are."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from rio.machine.confine import OutsideRoot
from rio.recording import Dataset
from rio.recording.format import export_dataset, get_format

#: From OUT/videos/observation.images.<cam>/ (LeRobot) or OUT/data/<cam>_rgb (Zarr): two levels above OUT.
ESCAPING = "x/../../../../escaped"


def _rename_camera(ds: Path, old: str, new: str) -> None:
    """Rename a camera consistently (step columns, layout, streams, recorded sha256): a dataset that passes
    every check, except that the new name is a path."""
    for ep in sorted(ds.glob("episode_*")):
        layout = json.loads((ep / "steps.json").read_text())
        layout["fields"] = [[n.replace(f"cam.{old}.", f"cam.{new}.", 1), d, s] for n, d, s in layout["fields"]]
        layout["cameras"] = {new if c == old else c: k for c, k in layout["cameras"].items()}
        (ep / "steps.json").write_text(json.dumps(layout))
        meta = json.loads((ep / "episode.json").read_text())
        streams = {}
        for key, s in meta["streams"].items():
            if s["camera"] == old:
                s["camera"], key = new, f"{new}.{s['kind']}"
            streams[key] = s
        meta["streams"] = streams
        data = (ep / "steps.json").read_bytes()
        meta["files"]["steps.json"] = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
        (ep / "episode.json").write_text(json.dumps(meta))


@pytest.fixture
def crafted(native, tmp_path) -> Path:
    ds = tmp_path / "in" / "ds"
    shutil.copytree(native, ds)
    _rename_camera(ds, "wrist", ESCAPING)
    return ds


@pytest.mark.parametrize("fmt", ["lerobot", "zarr"])
def test_a_camera_name_cannot_put_an_export_file_outside_its_output(crafted, tmp_path, fmt):
    if fmt == "zarr":
        pytest.importorskip("zarr")
    assert Dataset(crafted).damaged() == {}  # every check passes: only the writer can refuse it
    out = tmp_path / "a" / "out"
    out.parent.mkdir()
    with pytest.raises(OutsideRoot, match=r"x/\.\./\.\./\.\./\.\./escaped"):
        export_dataset(get_format(fmt, {"depth": False} if fmt == "zarr" else {}), Dataset(crafted), out)
    assert not out.exists() and not list(tmp_path.rglob("escaped*"))


def test_a_lerobot_import_reads_videos_only_inside_the_dataset(native, tmp_path):
    lr = tmp_path / "lr"
    export_dataset(get_format("lerobot"), Dataset(native), lr, episodes=[0])
    info = json.loads((lr / "meta" / "info.json").read_text())
    shutil.copytree(lr / "videos", tmp_path / "elsewhere")  # the same videos, outside: followed, they would import
    info["video_path"] = "../elsewhere/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    (lr / "meta" / "info.json").write_text(json.dumps(info))
    with pytest.raises(OutsideRoot, match=r"info\.json: video_path of 'observation\.images\.front'"):
        get_format("lerobot").import_(lr, tmp_path / "back")
