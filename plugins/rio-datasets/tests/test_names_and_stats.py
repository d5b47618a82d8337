"""What a LeRobot user needs from an export, checked on a real recording of a fake station (an arm whose
driver names its joints, a gripper, a camera configured at 15 fps) run by the real control loop:

- the driver's joint names and `gripper` are recorded in the episode and are the `names` of every export
  (LeRobot features, Zarr array attributes, HDF5 dataset attributes), also after `rio datasets merge`;
- `robot_type` is the station's arm driver;
- the episodes parquet holds each episode's stats (`stats/<feature>/<stat>`) computed from its own rows;
- an empty task is warned about, `-o task=...` fills it;
- `--overwrite` replaces an existing output (refused without it, naming the flag; kept if the new export fails);
- a camera's stream is encoded at its configured rate, the measured rate recorded beside it.
"""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from rio.cli import main as rio_main
from rio.recording import Dataset
from rio.recording.format import ExportError, export_dataset, get_format
from rio.recording.merge import merge_datasets
from rio.workflows.run import run_workflow

JOINTS = ["shoulder_pan", "shoulder_lift", "elbow_flex"]
NAMES = [*JOINTS, "gripper"]
STATION = f"""
name = "named"
rate_hz = 30
[middleware]
name = "thread"
[components.arm]
driver = "rio.fake_arm"
dof = 3
joint_names = {json.dumps(JOINTS)}
[components.gripper]
driver = "rio.fake_gripper"
[components.front_camera]
driver = "rio.fake_camera"
rate_hz = 15
"""


class Sweep:
    """Moves every joint a little each tick (so per-episode stats differ between episodes)."""

    name = "sweep"

    def __init__(self, scale: float) -> None:
        self.scale = scale

    def reset(self, loop) -> None:
        self.k = 0

    def step(self, tick) -> np.ndarray:
        self.k += 1
        return np.array([0.01 * self.k * self.scale, -0.005 * self.k, 0.002 * self.k, 0.02])

    def done(self) -> None:
        return None


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("named")
    station = tmp / "named.toml"
    station.write_text(STATION)
    for scale in (1.0, 2.0):
        run_workflow(str(station), lambda session, s=scale: Sweep(s), record=str(tmp / "ds"), duration=1.0, log=None)
    return tmp / "ds"


def test_the_recording_holds_the_drivers_names_the_robot_and_the_cameras_configured_rate(recorded, capsys,
                                                                                         monkeypatch):
    ep = Dataset(recorded).episode(0)
    assert ep.meta["action_names"] == NAMES
    assert ep.meta["observation_names"]["proprio"] == NAMES
    assert ep.meta["observation_names"]["proprio_joints"] == JOINTS
    assert ep.meta["robot_type"] == "rio.fake_arm"
    stream = ep.stream("front")
    assert stream["rate"] == 15.0  # configured, not guessed from the first frames
    assert stream["measured_rate"] is not None and stream["measured_rate"] > 0
    monkeypatch.setenv("COLUMNS", "250")  # one table row per line
    assert rio_main(["datasets", "info", str(recorded)]) == 0
    shown = " ".join(capsys.readouterr().out.split())
    assert f"front.rgb {stream['frames']}f@15.0 (measured {stream['measured_rate']:g})" in shown


def test_lerobot_export_names_robot_type_per_episode_stats_and_empty_task_warning(recorded, tmp_path):
    out = tmp_path / "lr"
    result = get_format("lerobot", {"codec": "h264"}).export(Dataset(recorded), out)
    assert result["robot_type"] == "rio.fake_arm"
    assert "without an instruction" in " ".join(result["warnings"])  # recorded without --instruction
    info = json.loads((out / "meta/info.json").read_text())
    assert info["robot_type"] == "rio.fake_arm"
    feats = info["features"]
    assert feats["action"]["names"] == NAMES and feats["observation.state"]["names"] == NAMES
    assert feats["observation.proprio_joints"]["names"] == JOINTS
    assert feats["observation.proprio_eef"]["names"] == ["x", "y", "z", "qw", "qx", "qy", "qz"]
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert len(rows) == 2
    means = []
    for row in rows:
        a, b = row["dataset_from_index"], row["dataset_to_index"]
        for key in ("action", "observation.state"):
            x = np.asarray(data.column(key).to_pylist()[a:b], np.float64)
            np.testing.assert_allclose(row[f"stats/{key}/min"], x.min(0), rtol=0, atol=1e-6)
            np.testing.assert_allclose(row[f"stats/{key}/max"], x.max(0), rtol=0, atol=1e-6)
            np.testing.assert_allclose(row[f"stats/{key}/mean"], x.mean(0), rtol=0, atol=1e-6)
            np.testing.assert_allclose(row[f"stats/{key}/std"], x.std(0), rtol=0, atol=1e-6)
            np.testing.assert_allclose(row[f"stats/{key}/q50"], np.quantile(x, 0.5, axis=0), rtol=0, atol=1e-6)
            assert row[f"stats/{key}/count"] == [b - a]
        assert np.asarray(row["stats/observation.images.front/mean"]).shape == (3, 1, 1)
        means.append(row["stats/action/max"][0])
    assert means[1] > means[0]  # each episode's own stats, not the dataset's twice
    tasked = tmp_path / "tasked"
    result = get_format("lerobot", {"codec": "h264", "task": "sweep the joints"}).export(Dataset(recorded), tasked)
    assert "warnings" not in result
    assert pq.read_table(tasked / "meta/tasks.parquet").column("task").to_pylist() == ["sweep the joints"]


def test_zarr_and_hdf5_carry_the_names(recorded, tmp_path):
    zarr = pytest.importorskip("zarr")
    get_format("zarr").export(Dataset(recorded), tmp_path / "z.zarr")
    root = zarr.open_group(str(tmp_path / "z.zarr"), mode="r")
    assert root["data/action"].attrs["names"] == NAMES and root["data/state"].attrs["names"] == NAMES
    assert root["data/proprio_joints"].attrs["names"] == JOINTS
    assert root.attrs["rio"]["robot_type"] == "rio.fake_arm"
    get_format("hdf5").export(Dataset(recorded), tmp_path / "aloha")
    with h5py.File(tmp_path / "aloha" / "episode_0.hdf5") as h:
        assert json.loads(h["action"].attrs["names"]) == NAMES
        assert json.loads(h["observations/qpos"].attrs["names"]) == NAMES
        assert h.attrs["robot_type"] == "rio.fake_arm"
    get_format("hdf5", {"style": "robomimic"}).export(Dataset(recorded), tmp_path / "rm.hdf5")
    with h5py.File(tmp_path / "rm.hdf5") as h:
        assert json.loads(h["data/demo_1/actions"].attrs["names"]) == NAMES


def test_merge_keeps_the_names_and_a_mixed_merge_names_each_element(recorded, tmp_path):
    from rio.recording.synthetic import record_synthetic

    other = tmp_path / "synthetic"  # 6 joints + gripper, recorded without an env: numbered names
    record_synthetic(str(other), episodes=1, steps=20, fps=30, cameras=("front",), depth=False)
    merged = tmp_path / "merged"
    merge_datasets([recorded, other], merged)
    out = tmp_path / "lr"
    get_format("lerobot", {"codec": "h264"}).export(Dataset(merged), out)
    info = json.loads((out / "meta/info.json").read_text())
    names = info["features"]["action"]["names"]
    assert len(names) == 7 and names[:3] == JOINTS  # the named robot's elements, padded after it
    assert info["robot_type"] == "rio.fake_arm"  # the one episode set that recorded one
    same = tmp_path / "same"
    shutil.copytree(recorded, same)
    merge_datasets([recorded, same], tmp_path / "twice")
    get_format("lerobot", {"codec": "h264"}).export(Dataset(tmp_path / "twice"), tmp_path / "lr2")
    feats = json.loads((tmp_path / "lr2/meta/info.json").read_text())["features"]
    assert feats["action"]["names"] == NAMES and feats["mask.action"]["names"] == NAMES


def test_overwrite_replaces_only_when_asked_and_keeps_the_old_output_if_the_new_one_fails(recorded, tmp_path,
                                                                                        capsys, monkeypatch):
    pytest.importorskip("zarr")
    out = tmp_path / "out.zarr"
    assert rio_main(["export", str(recorded), "-f", "zarr", str(out), "-e", "0"]) == 0
    assert rio_main(["export", str(recorded), "-f", "zarr", str(out)]) == 1
    assert "--overwrite" in " ".join(capsys.readouterr().err.split())
    assert rio_main(["export", str(recorded), "-f", "zarr", str(out), "--overwrite"]) == 0
    import zarr

    assert zarr.open_group(str(out), mode="r")["meta/episode_ends"].shape == (2,)  # the new export, both episodes
    f = get_format("zarr")

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(type(f), "_write", broken)
    with pytest.raises(ExportError, match="partial output was removed"):
        export_dataset(f, Dataset(recorded), out, overwrite=True)
    assert zarr.open_group(str(out), mode="r")["meta/episode_ends"].shape == (2,)  # the old one, put back
    assert [p.name for p in tmp_path.iterdir() if "rio-replaced" in p.name] == []
    with pytest.raises(ExportError, match="holds a RIO dataset"):
        export_dataset(get_format("zarr"), Dataset(recorded), tmp_path.parent, overwrite=True)


@pytest.mark.lerobot
def test_lerobot_itself_reads_names_robot_type_and_episode_stats(recorded, tmp_path, monkeypatch):
    """LeRobot's loader reads robot_type and names; its own `delete_episodes` rebuilds the dataset's stats from
    the per-episode `stats/...` columns of the episodes that remain, which must be that episode's own."""
    pytest.importorskip("lerobot", reason="lerobot is not installed (it pulls a CUDA torch): not run here")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    from lerobot.datasets.dataset_tools import delete_episodes
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = tmp_path / "lr"
    get_format("lerobot", {"task": "sweep the joints"}).export(Dataset(recorded), out)
    ds = LeRobotDataset("rio/named", root=out, video_backend="pyav")
    assert ds.meta.robot_type == "rio.fake_arm"
    assert ds.meta.features["action"]["names"] == NAMES
    assert ds.meta.features["observation.state"]["names"] == NAMES
    assert ds.meta.tasks.index.tolist() == ["sweep the joints"]
    rows = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    a, b = rows[1]["dataset_from_index"], rows[1]["dataset_to_index"]
    second = np.asarray(data.column("action").to_pylist()[a:b], np.float64)
    only_second = delete_episodes(ds, episode_indices=[0], output_dir=tmp_path / "second", repo_id="rio/second")
    stats = only_second.meta.stats["action"]
    np.testing.assert_allclose(stats["max"], second.max(0), atol=1e-6)
    np.testing.assert_allclose(stats["mean"], second.mean(0), atol=1e-6)
    assert int(np.asarray(stats["count"]).reshape(-1)[0]) == b - a
