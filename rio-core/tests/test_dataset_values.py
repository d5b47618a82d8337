"""An episode.json that is valid JSON with impossible values is damage (`rio.recording.checks`).

Its sha256 cannot tell: a dataset made or edited elsewhere can carry fps 0 or NaN, a length of 10^12, a
stream of a kind RIO does not record, or a "video" that is a text file whose sha256 was recorded with it.
Each is listed by `rio datasets info` (exit 1, the field named), refused by export in one line before
anything is written (they ended in tracebacks: a 258 TiB allocation, FFmpeg's InvalidDataError), and an
episode.json with impossible values is rebuilt from the data files by `rio datasets repair`."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from rio.cli import main as rio_main
from rio.recording import Dataset, repair_dataset
from rio.recording.synthetic import record_synthetic


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("values") / "ds"
    record_synthetic(str(root), episodes=2, steps=8, size=(32, 48), cameras=("front",), depth=False)
    return root


@pytest.fixture
def ds(recorded, tmp_path) -> Path:
    root = tmp_path / "ds"
    shutil.copytree(recorded, root)
    return root


def _meta(ds: Path) -> Path:
    return ds / "episode_000000" / "episode.json"


def _set(path: Path, fn) -> None:
    obj = json.loads(path.read_text())
    fn(obj)
    path.write_text(json.dumps(obj))  # json.dumps writes NaN as NaN, as a foreign writer may


def _not_a_video(ds: Path) -> None:
    video = ds / "episode_000000" / "front.rgb.mp4"
    video.write_text("this is not a video\n")
    digest = {"bytes": video.stat().st_size, "sha256": hashlib.sha256(video.read_bytes()).hexdigest()}
    _set(_meta(ds), lambda o: o["files"].__setitem__("front.rgb.mp4", digest))


CASES = {
    "fps 0": (lambda ds: _set(_meta(ds), lambda o: o.__setitem__("fps", 0)), "fps: 0 is not a rate"),
    "fps NaN": (lambda ds: _set(_meta(ds), lambda o: o.__setitem__("fps", float("nan"))), "fps: nan is not a rate"),
    "fps inf": (lambda ds: _set(_meta(ds), lambda o: o.__setitem__("fps", float("inf"))), "fps: inf is not a rate"),
    "length 10^12": (lambda ds: _set(_meta(ds), lambda o: o.__setitem__("length", 10**12)),
                     "length: 1000000000000 steps, but steps.bin holds 8"),
    "length -1": (lambda ds: _set(_meta(ds), lambda o: o.__setitem__("length", -1)), "length: -1 is not a number"),
    "kind ir": (lambda ds: _set(_meta(ds), lambda o: o["streams"]["front.rgb"].__setitem__("kind", "ir")),
                "streams['front.rgb'].kind: 'ir' is not a stream kind"),
    "frames 10^9": (lambda ds: _set(_meta(ds), lambda o: o["streams"]["front.rgb"].__setitem__("frames", 10**9)),
                    "streams['front.rgb'].frames: 1000000000 frames, but front.rgb.frames.bin holds 8"),
    "height 0": (lambda ds: _set(_meta(ds), lambda o: o["streams"]["front.rgb"].__setitem__("height", 0)),
                 "streams['front.rgb'].height: 0 is not an image size"),
    "wrong size": (lambda ds: _set(_meta(ds), lambda o: o["streams"]["front.rgb"].__setitem__("width", 640)),
                   "front.rgb.mp4 is 48x32, the stream says 640x32"),
    "not a video": (_not_a_video, "streams['front.rgb'].file: front.rgb.mp4 is not a video"),
    "unlisted stream file": (lambda ds: _set(_meta(ds), lambda o: o["files"].pop("front.rgb.mp4")),
                             "front.rgb.mp4 not listed in files"),
}


@pytest.mark.parametrize("case", CASES)
def test_impossible_values_are_damage_in_info_and_refused_by_export(ds, tmp_path, capsys, case):
    damage, said = CASES[case]
    damage(ds)
    assert rio_main(["datasets", "info", str(ds)]) == 1
    out = capsys.readouterr()
    text = " ".join((out.out + out.err).split())
    assert "Traceback" not in text and said in text and "DAMAGED" in text, text
    assert Dataset(ds).damaged().keys() == {"episode_000000"}
    exported = tmp_path / "out.zarr"
    assert rio_main(["export", str(ds), str(exported), "-f", "zarr"]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("error: ") and said in " ".join(err[0].split()), err
    assert not exported.exists()


def test_repair_rebuilds_an_episode_json_with_impossible_values_from_the_data(ds):
    _set(_meta(ds), lambda o: o.__setitem__("fps", 0))
    report = repair_dataset(ds)
    assert any("episode_000000" in q and "impossible values" in q for q in report.quarantined), report
    assert Dataset(ds).damaged() == {} and Dataset(ds).episode(0).fps == 30.0


def test_a_step_layout_naming_something_that_is_no_observation_class_is_refused(ds, monkeypatch):
    """steps.json names the class each step's observation is rebuilt with, and it is called with the step's
    fields: a dataset saying `os:system` (its sha256 recorded to match) must not get it called."""
    import os

    from rio.errors import ConfigError

    layout = ds / "episode_000000" / "steps.json"
    _set(layout, lambda o: o.__setitem__("observation_class", "os:system"))
    data = layout.read_bytes()
    _set(_meta(ds), lambda o: o["files"].__setitem__("steps.json", {"bytes": len(data),
                                                                      "sha256": hashlib.sha256(data).hexdigest()}))
    called = []
    monkeypatch.setattr(os, "system", lambda *a, **k: called.append((a, k)))
    with pytest.raises(ConfigError, match="'os:system' is not Observation or a subclass of it"):
        next(Dataset(ds).episode(0).steps(images=False))
    assert called == []
