"""Names read from a dataset never lead outside it (`rio.machine.confine`).

A dataset is something people download: its `dataset.json` `dir`, the keys of an `episode.json`'s
`files`, a stream's `file`/`frames_file`, the camera names in `steps.json`, and symlinks inside it are
data. Each case crafts one of them to point outside the dataset at a file that would be accepted if it
were followed (an intact episode, a real video, a file whose sha256 is recorded), and checks that every
reader reports it as damage or refuses it in one line naming the file and the field, and that no writer
(merge, repair, the recorder) creates or changes anything outside its own directory."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pytest

from rio.cli import main as rio_main
from rio.machine.confine import OutsideRoot, inside
from rio.recording import Dataset, Recorder, repair_dataset
from rio.recording import paths as L
from rio.recording.dataset import Episode
from rio.recording.merge import merge_datasets
from rio.recording.synthetic import record_synthetic, synthetic_step


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("paths") / "ds"
    record_synthetic(str(root), episodes=2, steps=8, size=(32, 48), cameras=("front",), depth=False)
    return root


@pytest.fixture
def ds(recorded, tmp_path) -> Path:
    """A fresh copy under tmp_path/inside/ds: tmp_path itself is 'outside' the dataset."""
    root = tmp_path / "inside" / "ds"
    shutil.copytree(recorded, root)
    return root


def _edit(path: Path, fn) -> None:
    obj = json.loads(path.read_text())
    fn(obj)
    path.write_text(json.dumps(obj))


def _tree(path: Path) -> dict[str, bytes]:
    """Every file under `path` with its bytes: what must be unchanged after a refusal."""
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def _info(ds: Path, capsys) -> tuple[int, str]:
    code = rio_main(["datasets", "info", str(ds)])
    out = capsys.readouterr()
    assert "Traceback" not in out.err + out.out
    return code, " ".join((out.out + out.err).split())


# -- the helper --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["../x", "a/../../x", "/etc/passwd", "", ".", "a\x00b"])
def test_inside_refuses_names_that_leave_the_root_naming_file_and_field(tmp_path, name):
    with pytest.raises(OutsideRoot) as e:
        inside(tmp_path, name, source="meta.json", field="files['x']")
    assert str(e.value).startswith("meta.json: files['x']: ") and "\n" not in str(e.value)


def test_inside_follows_symlinks_both_ways(tmp_path):
    root = tmp_path / "root"
    (root / "sub").mkdir(parents=True)
    (root / "out").symlink_to(tmp_path)
    (root / "in").symlink_to(root / "sub")
    with pytest.raises(OutsideRoot, match="points outside"):
        inside(root, "out/x", source="s", field="f")
    assert inside(root, "in/x", source="s", field="f") == root / "in" / "x"
    assert inside(root, "sub/../y", source="s", field="f") == root / "sub/../y"
    linked_root = tmp_path / "alias"  # the root itself behind a symlink is fine
    linked_root.symlink_to(root)
    assert inside(linked_root, "sub", source="s", field="f") == linked_root / "sub"


# -- dataset.json `dir` ------------------------------------------------------------------------------
@pytest.mark.parametrize("where", ["relative", "absolute", "symlink"])
def test_an_episode_dir_outside_the_dataset_is_damage_and_never_read(ds, tmp_path, capsys, where):
    outside = tmp_path / "outside_ep"  # an intact episode: followed, it would pass every check
    shutil.move(ds / "episode_000001", outside)
    if where == "symlink":
        (ds / "episode_000001").symlink_to(outside)
    else:
        _edit(ds / L.INDEX, lambda o: o["episodes"][1].__setitem__(
            "dir", "../../outside_ep" if where == "relative" else str(outside)))
    code, text = _info(ds, capsys)
    assert code == 1 and "dataset.json: episodes[1].dir" in text and "DAMAGED" in text
    with pytest.raises(OutsideRoot, match=r"dataset\.json: episodes\[1\]\.dir"):
        Dataset(ds).episode(1)
    assert Dataset(ds).episode(0).columns is not None  # the others are still readable
    out = tmp_path / "exported"
    assert rio_main(["export", str(ds), str(out), "-f", "zarr"]) == 1
    err = capsys.readouterr().err
    assert "episodes[1].dir" in err and "Traceback" not in err and not out.exists()


def test_a_symlinked_episode_outside_is_left_alone_by_repair_and_the_recorder(ds, tmp_path):
    outside = tmp_path / "someone_elses"
    shutil.copytree(ds / "episode_000001", outside)
    (outside / L.EPISODE_META).unlink()  # looks like an interrupted episode: repair would seal it
    (ds / "episode_000007.partial").symlink_to(outside)
    before = _tree(outside)
    report = repair_dataset(ds)
    assert not any("000007" in line for line in report.repaired + report.quarantined + report.removed)
    assert _tree(outside) == before and not (ds / "episode_000007").exists()
    assert L.scan(ds).keys() == {0, 1}
    with Recorder(ds, fps=30) as rec:  # numbers the next episode past what it can see, writes nothing there
        assert rec.next_index() == 2
    assert _tree(outside) == before


# -- episode.json `files` keys and streams -----------------------------------------------------------
def test_a_files_key_outside_the_episode_is_damage_and_its_file_is_never_hashed(ds, tmp_path, capsys):
    secret = tmp_path / "secret.txt"
    secret.write_text("not yours\n")
    digest = hashlib.sha256(secret.read_bytes()).hexdigest()  # recorded right: followed, it would pass
    _edit(ds / "episode_000000" / L.EPISODE_META, lambda o: o["files"].__setitem__(
        "../../../secret.txt", {"bytes": secret.stat().st_size, "sha256": digest}))
    code, text = _info(ds, capsys)
    assert code == 1 and "files['../../../secret.txt']" in text and "points outside" in text
    assert any("points outside" in p for p in Episode(ds / "episode_000000").verify())


def test_a_stream_file_outside_the_episode_is_damage_and_never_decoded(ds, tmp_path, capsys):
    video = tmp_path / "outside.mp4"
    shutil.copy(ds / "episode_000001" / "front.rgb.mp4", video)  # a real video of the right size
    _edit(ds / "episode_000000" / L.EPISODE_META, lambda o: (
        o["streams"]["front.rgb"].__setitem__("file", "../../../outside.mp4"),
        o["files"].__setitem__("../../../outside.mp4", o["files"].pop("front.rgb.mp4"))))
    code, text = _info(ds, capsys)
    assert code == 1 and "streams['front.rgb'].file" in text
    ep = Dataset(ds, allow_damaged=True).episode(0)  # not even --allow-damaged follows it
    with pytest.raises(OutsideRoot, match=r"episode\.json: streams\['front\.rgb'\]\.file"):
        next(ep.frames("front"))


def test_a_symlinked_video_pointing_outside_is_damage(ds, tmp_path, capsys):
    video = ds / "episode_000000" / "front.rgb.mp4"
    shutil.copy(video, tmp_path / "same.mp4")  # the same bytes: its sha256 matches what was recorded
    video.unlink()
    video.symlink_to(tmp_path / "same.mp4")
    code, text = _info(ds, capsys)
    assert code == 1 and "files['front.rgb.mp4']" in text and "points outside" in text


# -- writers -----------------------------------------------------------------------------------------
def test_merge_refuses_an_input_naming_a_file_outside_and_writes_nothing_outside(ds, tmp_path, capsys):
    deep = tmp_path / "a" / "b" / "c"
    shutil.copytree(ds, deep / "ds")
    payload = tmp_path / "payload"
    payload.write_bytes(b"x")
    name = "../../../../payload"  # from deep/ds/episode_000000: tmp_path/payload; from out/episode_*: outside
    _edit(deep / "ds" / "episode_000000" / L.EPISODE_META, lambda o: o["files"].__setitem__(
        name, {"bytes": 1, "sha256": hashlib.sha256(b"x").hexdigest()}))
    out = tmp_path / "merged"
    assert rio_main(["datasets", "merge", str(deep / "ds"), str(ds), str(out)]) == 1
    err = capsys.readouterr().err
    assert "points outside" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "inside", "payload"]


def test_the_merge_writer_itself_never_writes_outside_its_output(ds, tmp_path, monkeypatch):
    """Even past the reader's check (made a no-op here), the writer confines each name it copies."""
    shutil.copytree(ds, tmp_path / "b")
    (ds / "escape").write_bytes(b"x")  # inside the input: the source side passes, the destination does not
    _edit(ds / "episode_000000" / L.EPISODE_META, lambda o: o["files"].__setitem__(
        "../escape", {"bytes": 1, "sha256": hashlib.sha256(b"x").hexdigest()}))
    monkeypatch.setattr(Episode, "check", lambda self: None)
    monkeypatch.setattr(Episode, "file", lambda self, name, field: self.path / name)
    out = tmp_path / "out" / "merged"
    with pytest.raises(OutsideRoot, match=r"files\['\.\./escape'\]"):
        merge_datasets([ds, tmp_path / "b"], out)
    assert not out.exists() and not (out.parent / "escape").exists()


def test_repair_quarantines_a_partial_whose_layout_names_a_camera_outside(ds, tmp_path):
    partial = ds / "episode_000001.partial"
    os.rename(ds / "episode_000001", partial)
    (partial / L.EPISODE_META).unlink()
    _edit(partial / L.STEPS_SCHEMA, lambda o: o["cameras"].__setitem__("../../../../esc", ["rgb"]))
    (tmp_path / "esc.rgb.frames.bin").write_bytes(bytes(32))  # what repair would truncate, were it followed
    before = _tree(tmp_path / "inside") | {"esc": (tmp_path / "esc.rgb.frames.bin").read_bytes()}
    report = repair_dataset(ds)
    assert any("names a camera outside" in q for q in report.quarantined), report
    assert (tmp_path / "esc.rgb.frames.bin").read_bytes() == before["esc"]
    assert not list(tmp_path.glob("esc.rgb.mp4*"))


def test_the_recorder_refuses_a_camera_name_that_leaves_the_episode(tmp_path):
    root = tmp_path / "inside" / "ds"
    step = synthetic_step(0, 1.0, {"../../../escaped": (bytes_image(), 1.0)})
    with pytest.raises(OutsideRoot, match="camera '../../../escaped'"), Recorder(root, fps=30, cameras=True) as rec:
        rec.add(step)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["inside"]
    assert not L.scan(root)  # the episode that could not start is not left behind


def bytes_image():
    import numpy as np

    return np.zeros((16, 16, 3), np.uint8)


def test_a_calibration_name_cannot_reach_outside_its_folder_through_a_symlink(tmp_path, monkeypatch):
    from rio.machine.calibration_files import calibration_path

    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "cfg"))
    folder = tmp_path / "cfg" / "rio" / "calibration" / "so100-follower"
    folder.mkdir(parents=True)
    (folder / "left.json").symlink_to(tmp_path / "elsewhere.json")
    with pytest.raises(OutsideRoot, match="calibration 'left'"):
        calibration_path("left", "so100-follower")
    assert calibration_path("right", "so100-follower") == folder / "right.json"
    assert calibration_path(str(tmp_path / "mine.json"), "so100-follower") == tmp_path / "mine.json"  # a path: as given
