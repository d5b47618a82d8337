"""native -> each format -> native again: state exact (LeRobot: exact float32), depth lossless,
images within codec tolerance; plus the exported layouts as other tools read them."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from rio.cli import main as rio_main
from rio.recording import Dataset
from rio.recording.format import get_format


def _compare(a: Dataset, b: Dataset, exact: bool = True, depth: bool = True, img_tol: float = 8.0) -> None:
    assert len(a) == len(b)
    for e0, e1 in zip(a, b, strict=False):
        assert len(e0) == len(e1) and e0.instruction == e1.instruction
        for col in ("action", "obs.proprio", "obs.proprio_eef", "obs.gripper_width"):
            x0, x1 = e0.column(col), e1.column(col)
            if exact:
                np.testing.assert_array_equal(x0, x1)
            else:
                np.testing.assert_array_equal(x0.astype(np.float32), x1)
        for cam in ("front", "wrist"):
            f0 = np.stack(list(e0.step_frames(cam))).astype(int)
            f1 = np.stack(list(e1.step_frames(cam))).astype(int)
            assert np.abs(f0 - f1).mean() < img_tol
        if depth:
            np.testing.assert_array_equal(np.stack(list(e0.step_frames("front", "depth"))),
                                          np.stack(list(e1.step_frames("front", "depth"))))
        assert type(next(e1.steps()).observation).__name__ == "SingleArmObs"


def test_zarr_round_trip_and_layout(native, tmp_path):
    zarr = pytest.importorskip("zarr")
    out = tmp_path / "replay.zarr"
    f = get_format("zarr")
    f.export(Dataset(native), out)
    root = zarr.open_group(str(out), mode="r")
    assert root["meta/episode_ends"][:].tolist() == [20, 40]
    assert root["data/front_rgb"].shape == (40, 48, 64, 3) and root["data/state"].shape == (40, 7)
    assert root["data/front_depth"].dtype == np.uint16
    assert (out / "data" / ".zarray").exists() or (out / "data" / "state" / ".zarray").exists()  # Zarr format 2
    f.import_(out, tmp_path / "back")
    _compare(Dataset(native), Dataset(tmp_path / "back"))


@pytest.mark.parametrize("style", ["aloha", "robomimic"])
def test_hdf5_round_trip(native, tmp_path, style):
    import h5py

    out = tmp_path / ("aloha" if style == "aloha" else "demo.hdf5")
    f = get_format("hdf5", {"style": style})
    f.export(Dataset(native), out)
    if style == "aloha":
        with h5py.File(out / "episode_1.hdf5") as h:
            assert h["action"].shape == (20, 7) and h["observations/qpos"].shape == (20, 7)
            assert h["observations/images/wrist"].shape == (20, 48, 64, 3)
    else:
        with h5py.File(out) as h:
            assert h["data"].attrs["total"] == 40 and h["data/demo_0/actions"].shape == (20, 7)
            assert h["data/demo_1/obs/front_image"].shape == (20, 48, 64, 3) and h["data/demo_1/dones"][-1] == 1
    f.import_(out, tmp_path / "back")
    _compare(Dataset(native), Dataset(tmp_path / "back"))


def test_lerobot_paths_and_round_trip(native, tmp_path):
    out = tmp_path / "lr"
    result = get_format("lerobot", {"codec": "h264"}).export(Dataset(native), out)
    assert result["skipped_streams"] == ["front.depth"]
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 30 and info["total_frames"] == 40
    assert info["features"]["observation.images.front"]["dtype"] == "video"
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    ts = np.asarray(data.column("timestamp"))
    np.testing.assert_allclose(ts[:20], np.arange(20) / 30, atol=1e-6)
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert eps[1]["videos/observation.images.front/from_timestamp"] == pytest.approx(20 / 30)
    assert (out / "videos/observation.images.wrist/chunk-000/file-000.mp4").exists()
    stats = json.loads((out / "meta/stats.json").read_text())
    assert np.asarray(stats["observation.images.front"]["mean"]).shape == (3, 1, 1)
    get_format("lerobot").import_(out, tmp_path / "back")
    _compare(Dataset(native), Dataset(tmp_path / "back"), exact=False, depth=False, img_tol=10.0)


def test_cli_export_info_repair(native, tmp_path, capsys):
    assert rio_main(["export", str(native), "--format", "zarr", str(tmp_path / "x.zarr")]) == 0
    assert rio_main(["datasets", "info", str(native), "--verify"]) == 0
    assert rio_main(["datasets", "repair", str(native)]) == 0
    out = capsys.readouterr().out
    assert "verified" in out and "nothing to repair" in out
    assert rio_main(["export", str(native), "-f", "zarr", str(tmp_path / "y.zarr"), "-o", "nope=1"]) == 1


@pytest.mark.lerobot
def test_lerobot_loads_the_export(native, tmp_path, monkeypatch):
    pytest.importorskip("lerobot")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = tmp_path / "lr"
    get_format("lerobot").export(Dataset(native), out)
    ds = LeRobotDataset("rio/test", root=out, video_backend="pyav")
    assert len(ds) == 40 and ds.meta.total_episodes == 2
    for i in (0, 19, 20, 39):
        item = ds[i]
        assert tuple(item["observation.images.front"].shape) == (3, 48, 64)
        assert item["task"] == "pick up the cube"


def test_cli_export_refuses_damaged_episodes_and_leaves_no_output(native, tmp_path, capsys):
    """An all-zero steps.bin is refused in one line naming episode and file (no output written);
    --allow-damaged exports it with a warning."""
    import shutil

    pytest.importorskip("zarr")
    ds = tmp_path / "ds"
    shutil.copytree(native, ds)
    steps = ds / "episode_000001" / "steps.bin"
    steps.write_bytes(bytes(steps.stat().st_size))
    out = tmp_path / "x.zarr"
    assert rio_main(["export", str(ds), "-f", "zarr", str(out)]) == 1
    err = " ".join(capsys.readouterr().err.split())
    assert "episode_000001: damaged episode: steps.bin: changed since it was recorded" in err
    assert "Traceback" not in err and not out.exists()
    assert rio_main(["export", str(ds), "-f", "zarr", str(out), "--episodes", "0"]) == 0
    capsys.readouterr()
    assert rio_main(["export", str(ds), "-f", "zarr", str(tmp_path / "y.zarr"), "--allow-damaged"]) == 0
    assert "damaged episode used anyway" in " ".join(capsys.readouterr().err.split())


def test_a_failing_export_removes_its_partial_output(native, tmp_path, monkeypatch):
    from rio.recording.format import ExportError, export_dataset

    pytest.importorskip("zarr")

    def boom(ep):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("rio_datasets.zarr_format.lowdim", boom)
    out = tmp_path / "x.zarr"
    with pytest.raises(ExportError, match=r"No space left on device \[ENOSPC\]; its partial output was removed"):
        export_dataset(get_format("zarr"), Dataset(native), out)
    assert not out.exists()
