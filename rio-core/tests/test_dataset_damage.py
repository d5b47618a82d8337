"""Datasets refuse corrupted data: a file that fails its recorded sha256 is never read as if it were
good (DamagedEpisode, or a warning with allow_damaged), damaged metadata is one line naming the file,
repair rebuilds what survives and deletes nothing, a full disk stops the recorder with one error, and
a failed export leaves no partial output."""

from __future__ import annotations

import errno
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from rio import clock
from rio.cli import main as rio_main
from rio.errors import ConfigError
from rio.recording import (
    DamagedEpisode,
    DamagedEpisodeWarning,
    Dataset,
    DiskFull,
    Recorder,
    export_dataset,
    repair_dataset,
)
from rio.recording import paths as L
from rio.recording import recorder as recorder_mod
from rio.recording.durable import AppendFile
from rio.recording.format import DatasetFormat, ExportError
from rio.recording.synthetic import record_synthetic
from rio.schema import SingleArmObs, Step


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """Two short episodes with cameras (front rgb + depth, wrist rgb); copied by `ds` before damage."""
    root = tmp_path_factory.mktemp("damage") / "ds"
    record_synthetic(str(root), episodes=2, steps=12, size=(32, 48))
    return root


@pytest.fixture
def ds(recorded, tmp_path) -> Path:
    root = tmp_path / "ds"
    shutil.copytree(recorded, root)
    return root


def _zero(path: Path) -> None:
    """Overwrite a file with zeros of the same size (what the probe did to steps.bin)."""
    path.write_bytes(bytes(path.stat().st_size))


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1, err
    return lines[0]


# -- reading refuses damaged files ------------------------------------------------------------------
def test_reading_a_damaged_episode_is_refused_naming_episode_and_file(ds):
    good = Dataset(ds).episode(1).column("action")
    _zero(ds / "episode_000001" / L.STEPS)
    with pytest.raises(DamagedEpisode, match=r"episode_000001.*steps\.bin: changed since it was recorded"):
        Dataset(ds).episode(1).column("action")
    with pytest.raises(DamagedEpisode):
        list(Dataset(ds).episode(1).steps(images=False))
    assert len(Dataset(ds).episode(0).column("action")) == 12  # the intact one is still readable
    with pytest.warns(DamagedEpisodeWarning, match="steps.bin"):
        zeros = Dataset(ds, allow_damaged=True).episode(1).column("action")
    assert not zeros.any() and good.any()


def test_a_damaged_video_is_refused_when_its_frames_are_read(ds):
    video = ds / "episode_000000" / L.video_file("front", "rgb")
    video.write_bytes(video.read_bytes()[:-10])
    ep = Dataset(ds).episode(0)
    assert len(ep.column("action")) == 12  # the steps are intact
    with pytest.raises(DamagedEpisode, match=r"front\.rgb\.mp4: changed"):
        next(ep.frames("front"))
    with pytest.raises(DamagedEpisode, match="front.rgb.mp4"):
        ep.check()


# -- rio datasets info --------------------------------------------------------------------------------
def test_info_verifies_by_default_and_names_damaged_files(ds, capsys):
    assert rio_main(["datasets", "info", str(ds)]) == 0
    assert "verified" in capsys.readouterr().out
    _zero(ds / "episode_000001" / L.STEPS)
    (ds / "episode_000000" / L.frames_file("wrist", "rgb")).unlink()
    assert rio_main(["datasets", "info", str(ds)]) == 1
    out = capsys.readouterr()
    err = " ".join(out.err.split())
    assert "episode_000001 is damaged: steps.bin: changed since it was recorded" in err
    assert "episode_000000 is damaged: wrist.rgb.frames.bin: missing" in err
    assert "DAMAGED" in out.out
    assert rio_main(["datasets", "info", str(ds), "--no-verify"]) == 0
    assert "not verified" in capsys.readouterr().out
    assert rio_main(["datasets", "info", str(ds), "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert sorted(report["damaged"]) == ["episode_000000", "episode_000001"]


# -- export ------------------------------------------------------------------------------------------
class _Npz(DatasetFormat):
    """A minimal format: every episode's actions into OUT/episode_K.npy; fails after `fail_after` files."""

    name = "npz-test"

    def __init__(self, fail_after: int | None = None):
        self.fail_after = fail_after

    def export(self, dataset, out, *, episodes=None, progress=None):
        out.mkdir(parents=True, exist_ok=True)
        chosen = episodes if episodes is not None else [e["index"] for e in dataset.episodes]
        for n, k in enumerate(chosen):
            if self.fail_after is not None and n >= self.fail_after:
                raise OSError(errno.ENOSPC, "No space left on device")
            np.save(out / f"episode_{k}.npy", dataset.episode(k).column("action"))
        return {"episodes": len(chosen)}


def test_export_refuses_a_damaged_episode_before_writing(ds, tmp_path):
    _zero(ds / "episode_000001" / L.STEPS)
    out = tmp_path / "out"
    with pytest.raises(DamagedEpisode, match=r"episode_000001.*steps\.bin"):
        export_dataset(_Npz(), Dataset(ds), out)
    assert not out.exists()
    assert export_dataset(_Npz(), Dataset(ds), out, episodes=[0]) == {"episodes": 1}
    with pytest.warns(DamagedEpisodeWarning, match="episode_000001"):
        export_dataset(_Npz(), Dataset(ds, allow_damaged=True), tmp_path / "anyway")
    assert not np.load(tmp_path / "anyway" / "episode_1.npy").any()


def test_a_failed_export_removes_what_it_wrote_and_only_that(ds, tmp_path):
    out = tmp_path / "out"
    full = r"the export failed: No space left on device \[ENOSPC\]; its partial output was removed"
    with pytest.raises(ExportError, match=full):  # one line, not the writer's OSError and its traceback
        export_dataset(_Npz(fail_after=1), Dataset(ds), out)
    assert not out.exists()
    out.mkdir()  # an empty directory: kept, what the export wrote into it removed
    with pytest.raises(ExportError, match=full):
        export_dataset(_Npz(fail_after=1), Dataset(ds), out)
    assert out.is_dir() and list(out.iterdir()) == []
    (out / "mine.txt").write_text("keep me")
    with pytest.raises(ExportError, match="exists and is not empty; --overwrite"):
        export_dataset(_Npz(fail_after=1), Dataset(ds), out)
    with pytest.raises(ExportError, match=full):  # replacing it: the old output comes back whole
        export_dataset(_Npz(fail_after=1), Dataset(ds), out, overwrite=True)
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt"]
    assert [p.name for p in tmp_path.iterdir() if "rio-replaced" in p.name] == []


@pytest.mark.parametrize("episodes,why", [("5-2", "ends before it starts"), ("1,x", "'x' is not an episode"),
                                          ("", "'' is not an episode")])
def test_export_bad_episode_lists_are_one_line(ds, tmp_path, capsys, episodes, why):
    assert rio_main(["export", str(ds), str(tmp_path / "o"), "-f", "zarr", "--episodes", episodes]) == 1
    assert why in _one_line_error(capsys)


def test_export_and_info_of_a_missing_dataset_are_one_line(tmp_path, capsys):
    assert rio_main(["export", str(tmp_path / "nope"), str(tmp_path / "o"), "-f", "zarr"]) == 1
    assert "no dataset at" in _one_line_error(capsys)
    assert rio_main(["datasets", "info", str(tmp_path / "nope")]) == 1
    assert "no dataset at" in _one_line_error(capsys)


# -- damaged metadata -------------------------------------------------------------------------------
@pytest.mark.parametrize("garbage", [b"{\"format\": \"rio-dat", b"\x00" * 64, b"\xff\xfe not utf-8", b"[]",
                                     b"{\"format\": \"rio-dataset\", \"episodes\": [{\"index\": \"x\"}]}"])
def test_a_damaged_index_is_one_line_and_repair_rebuilds_it(ds, capsys, garbage):
    (ds / L.INDEX).write_bytes(garbage)
    with pytest.raises(ConfigError, match="dataset.json"):
        Dataset(ds)
    station = ds.parent / "st.toml"  # a station that exists: the dataset is what must be refused
    station.write_text('name = "s"\n[components.arm]\ndriver = "rio.fake_arm"\n')
    for cmd in (["datasets", "info", str(ds)], ["replay", str(ds), "-s", str(station)],
                ["export", str(ds), str(ds.parent / "o"), "-f", "zarr"]):
        assert rio_main(cmd) == 1
        assert "dataset.json" in _one_line_error(capsys)
    report = repair_dataset(ds)
    assert any("dataset.json" in q for q in report.quarantined)
    assert [q.name.split("-")[0] for q in (ds / L.QUARANTINE).iterdir()] == ["dataset.json"]
    assert [e["index"] for e in Dataset(ds).episodes] == [0, 1]
    assert rio_main(["datasets", "info", str(ds)]) == 0


def test_a_damaged_episode_json_is_reported_and_rebuilt_from_the_data(ds, capsys):
    want = Dataset(ds).episode(1).columns.copy()
    frames = len(list(Dataset(ds).episode(1).frames("front")))
    meta = ds / "episode_000001" / L.EPISODE_META
    meta.write_bytes(meta.read_bytes()[:40])
    with pytest.raises(ConfigError, match=r"episode_000001/episode\.json: damaged"):
        Dataset(ds).episode(1)
    assert rio_main(["datasets", "info", str(ds)]) == 1
    assert "episode_000001/episode.json: damaged" in " ".join(capsys.readouterr().err.split())
    report = repair_dataset(ds)
    assert any("episode.json was damaged; rebuilt from its data files" in r for r in report.repaired)
    assert not report.damaged
    ep = Dataset(ds).episode(1)
    assert ep.meta["repaired"] and ep.verify() == []
    np.testing.assert_array_equal(ep.columns, want)
    assert len(list(ep.frames("front"))) == frames
    assert [q.name.split("-")[0] for q in (ds / L.QUARANTINE).iterdir()] == ["episode_000001.episode.json"]


# -- repair keeps data ---------------------------------------------------------------------------------
def _as_interrupted(ds: Path, index: int) -> Path:
    """Turn a finished episode back into what a crash leaves: a .partial without episode.json."""
    partial = ds / L.partial_dir_name(index)
    (ds / L.episode_dir_name(index)).rename(partial)
    (partial / L.EPISODE_META).unlink()
    return partial


def test_an_interrupted_episode_whose_video_holds_only_headers_keeps_its_steps(ds):
    want = Dataset(ds).episode(1).columns.copy()
    partial = _as_interrupted(ds, 1)
    for cam, kind in (("front", "rgb"), ("front", "depth"), ("wrist", "rgb")):
        video = partial / L.video_file(cam, kind)
        video.write_bytes(video.read_bytes()[:48])  # a header, no decodable frame
    report = repair_dataset(ds)
    assert not report.quarantined and not report.removed and not report.damaged
    ep = Dataset(ds).episode(1)
    assert len(ep) == 12 and ep.meta["repaired"] and ep.streams == {}
    assert sorted(ep.meta["missing_streams"]) == ["front.depth", "front.rgb", "wrist.rgb"]
    for name in want.dtype.names:
        if name.startswith("cam."):
            assert (ep.column(name) == -1).all()  # frames marked missing
        else:
            np.testing.assert_array_equal(ep.column(name), want[name])
    steps = list(ep.steps())
    assert len(steps) == 12 and not steps[0].observation.cameras
    assert (ep.path / L.video_file("front", "rgb")).exists()  # the undecodable bytes are not deleted


def test_an_interrupted_episode_repair_cannot_use_is_quarantined_not_deleted(ds):
    partial = _as_interrupted(ds, 1)
    (partial / L.STEPS_SCHEMA).write_text("{not json")
    steps = (partial / L.STEPS).read_bytes()
    report = repair_dataset(ds)
    assert len(report.quarantined) == 1 and "steps.json" in report.quarantined[0] and not report.removed
    [aside] = (ds / L.QUARANTINE).iterdir()
    assert aside.name.startswith("episode_000001.partial-") and (aside / L.STEPS).read_bytes() == steps
    assert [e["index"] for e in Dataset(ds).episodes] == [0]
    with Recorder(ds, fps=30) as rec:  # a quarantined episode's number is never reused
        assert rec.next_index() == 2


# -- a full disk -----------------------------------------------------------------------------------
def _step(i: int, t0: float) -> Step:
    a = np.array([0.01 * i, 0.2, 0.3, 0.04])
    return Step(i, SingleArmObs(proprio=a.copy()), None, a, {"t_obs": t0 + i / 30})


def test_no_episode_starts_without_free_space(tmp_path, monkeypatch):
    monkeypatch.setattr(recorder_mod, "free_bytes", lambda path: 5_000_000)
    with Recorder(tmp_path / "ds", fps=30) as rec:
        with pytest.raises(DiskFull, match=r"ds: not starting an episode: 5\.0 MB free"):
            rec.add(_step(0, clock.now()))
    assert not list((tmp_path / "ds").glob("episode_*"))


def test_running_out_of_space_while_recording_keeps_the_episode(tmp_path, monkeypatch):
    free = {"bytes": 10**9}
    monkeypatch.setattr(recorder_mod, "free_bytes", lambda path: free["bytes"])
    t0 = clock.now()
    with pytest.raises(DiskFull) as err, Recorder(tmp_path / "ds", fps=30) as rec:
        for i in range(100):
            if i == 40:
                free["bytes"] = 1_000_000
            rec.add(_step(i, t0))
    msg = str(err.value)
    assert str(tmp_path / "ds") in msg and "1.0 MB free" in msg and "kept as episode_000000" in msg
    assert err.value.__suppress_context__ or err.value.__context__ is None  # no chained traceback
    ep = Dataset(tmp_path / "ds").episode(0)
    assert len(ep) == 60 and ep.meta["ended_by"] == "disk almost full" and ep.verify() == []


def test_enospc_while_writing_leaves_a_repairable_episode(tmp_path, monkeypatch):
    real_write = AppendFile.write
    writes = {"n": 0}

    def write(self, data):
        if self.path.name == L.STEPS:
            writes["n"] += 1
            if writes["n"] > 25:
                raise OSError(errno.ENOSPC, "No space left on device")
        real_write(self, data)

    monkeypatch.setattr(AppendFile, "write", write)
    t0 = clock.now()
    with pytest.raises(DiskFull) as err, Recorder(tmp_path / "ds", fps=30) as rec:
        for i in range(100):
            rec.add(_step(i, t0))
    msg = str(err.value)
    assert "the disk is full" in msg and "episode 0 (25 steps) was left as episode_000000.partial" in msg
    assert err.value.__suppress_context__ or err.value.__context__ is None  # no chained traceback
    monkeypatch.setattr(AppendFile, "write", real_write)
    report = repair_dataset(tmp_path / "ds")
    assert report.repaired and not report.quarantined
    ep = Dataset(tmp_path / "ds").episode(0)
    assert len(ep) == 25
    np.testing.assert_allclose(ep.column("action")[:, 0], 0.01 * np.arange(25), rtol=1e-6)


def test_a_dataset_where_nothing_can_be_created_is_one_error(tmp_path):
    """`--record` is tried by the command line first; a script calling the recorder gets one error too."""
    from rio.recording import RecordingError

    (tmp_path / "file").write_text("x")
    with pytest.raises(RecordingError, match=r"file/ds: cannot record here \(Not a directory\)"), \
            Recorder(tmp_path / "file" / "ds", fps=30):
        pass
