"""`rio datasets view`: an episode in rerun, checked by reading the written .rrd back with rerun's own
reader (`rerun.chunk.RrdReader`): every camera frame once, one row per step for each joint's state and
action, the gripper, the end effector's strip and pose; the episode's own timestamps; headless saves
and says where; frames are streamed; bad input, damage and a missing rerun are one line each."""

from __future__ import annotations

import shutil
import sys
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from rio.cli import main as rio_main
from rio.recording import Dataset
from rio.recording import paths as L
from rio.recording.synthetic import record_synthetic
from rio.testing import block_import

STEPS = 15
ARM = [("arm", 6), ("gripper", 1)]
NAMES = [f"arm.{i}" for i in range(6)] + ["gripper"]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """Two episodes: front (rgb + depth) and wrist (rgb) cameras, an eef pose, action names from an env."""
    root = tmp_path_factory.mktemp("view") / "ds"
    env = SimpleNamespace(station="synthetic", robot=SimpleNamespace(name="so100", action_parts=lambda: ARM))
    record_synthetic(str(root), episodes=2, steps=STEPS, size=(32, 48), env=env)
    assert Dataset(root).episode(1).meta["action_names"] == NAMES
    return root


@pytest.fixture
def ds(recorded, tmp_path) -> Path:
    root = tmp_path / "ds"
    shutil.copytree(recorded, root)
    return root


@pytest.fixture
def rr(monkeypatch):
    """rerun, with a viewer that must not be spawned (a test that means to spawn replaces it again)."""
    rr = pytest.importorskip("rerun")

    def no_viewer(*_a, **_k):
        raise AssertionError("rerun's viewer was spawned")

    monkeypatch.setattr(rr, "spawn", no_viewer)
    return rr


def _read(rr, path: Path) -> tuple[Counter, Counter, dict[str, list]]:
    """(temporal rows, static rows, {entity: record batches}) by entity path, from rerun's own reader."""
    temporal, static, batches = Counter(), Counter(), {}
    for chunk in rr.chunk.RrdReader(path).stream():
        (static if chunk.is_static else temporal)[chunk.entity_path] += chunk.num_rows
        batches.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    return temporal, static, batches


def _column(batches: list, name: str) -> np.ndarray:
    out = []
    for b in batches:
        col = b.column(b.schema.get_field_index(name))
        out.extend(v.value if hasattr(v, "value") else v.as_py() for v in col)
    return np.array(out)


def _views(rr, path: Path) -> dict[str, str]:
    """{origin: view kind} of the blueprint stored in the .rrd (the viewer's layout)."""
    reader = rr.chunk.RrdReader(path)
    (store,) = reader.blueprints()
    out = {}
    for chunk in reader.stream(store=store):
        b = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in b.schema.names:
            for origin, kind in zip(b.column("ViewBlueprint:space_origin").to_pylist(),
                                    b.column("ViewBlueprint:class_identifier").to_pylist(), strict=True):
                out[origin[0]] = kind[0]
    return out


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


def test_save_writes_every_camera_frame_joint_gripper_and_eef(ds, rr, tmp_path, capsys):
    out = tmp_path / "out" / "ep1.rrd"
    assert rio_main(["datasets", "view", str(ds), "--episode", "1", "--save", str(out)]) == 0
    said = capsys.readouterr().out
    assert str(out) in said and "episode 1" in said and "no display" not in said
    temporal, static, batches = _read(rr, out)
    ep = Dataset(ds).episode(1)
    for key, info in ep.streams.items():  # each frame once, whatever the step rate
        assert temporal[f"/cameras/{info['camera']}/{info['kind']}"] == info["frames"] == STEPS, key
    for name in NAMES:  # per joint, named from the episode's action names: state and action
        assert temporal[f"/joints/{name}/state"] == temporal[f"/joints/{name}/action"] == STEPS
    assert temporal["/gripper/gripper_width"] == STEPS
    assert temporal["/state/proprio_joints/5"] == STEPS  # other observation fields, by their names
    assert temporal["/world/proprio_eef/pose"] == STEPS  # the pose at every step
    assert static["/world/proprio_eef/trajectory"] == 1  # the whole path, one line strip
    strips = np.array(_column(batches["/world/proprio_eef/trajectory"], "LineStrips3D:strips").tolist())
    assert strips.shape == (1, 1, STEPS, 3)  # one row holding one strip through every step's position
    np.testing.assert_allclose(strips[0, 0], ep.column("obs.proprio_eef")[:, :3], atol=1e-6)
    # the layout: a view per camera stream, one plot per joint (state with action), gripper, eef in 3D
    assert _views(rr, out) == {"cameras/front/rgb": "2D", "cameras/front/depth": "2D", "cameras/wrist/rgb": "2D",
                               "world": "3D", **{f"joints/{n}": "TimeSeries" for n in NAMES},
                               "gripper": "TimeSeries", "state/proprio_joints": "TimeSeries"}
    # values and the episode's own timestamps: "time" is seconds from the start, "step" counts steps
    rows = batches["/joints/arm.2/action"]
    np.testing.assert_allclose(_column(rows, "Scalars:scalars").ravel(), ep.column("action")[:, 2], rtol=1e-6)
    np.testing.assert_array_equal(_column(rows, "step"), np.arange(STEPS))
    seconds = _column(rows, "time").astype("timedelta64[ns]").astype(np.int64) / 1e9
    np.testing.assert_allclose(seconds, ep.column("t") - ep.meta["t_start"], atol=1e-6)
    frames_at = _column(batches["/cameras/front/rgb"], "time").astype("timedelta64[ns]").astype(np.int64) / 1e9
    np.testing.assert_allclose(frames_at, ep.frame_times("front")["t"] - ep.meta["t_start"], atol=1e-6)


def test_headless_without_save_writes_the_file_and_says_where(ds, rr, tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.chdir(tmp_path)
    assert rio_main(["datasets", "view", str(ds)]) == 0
    written = tmp_path / "ds-episode_000000.rrd"
    said = capsys.readouterr().out
    assert "no display" in said and written.name in said
    temporal, _, _ = _read(rr, written)
    assert temporal["/cameras/wrist/rgb"] == STEPS and temporal["/joints/gripper/state"] == STEPS


def test_with_a_display_the_viewer_is_spawned(ds, rr, tmp_path, monkeypatch, capsys):
    spawned = tmp_path / "spawned.rrd"
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(rr, "spawn", lambda *_a, **_k: rr.save(str(spawned)))  # the viewer's stream, kept
    monkeypatch.chdir(tmp_path)
    assert rio_main(["datasets", "view", str(ds), "-e", "0"]) == 0
    assert "sent to rerun's viewer" in capsys.readouterr().out
    assert _read(rr, spawned)[0]["/cameras/front/depth"] == STEPS
    assert list(tmp_path.glob("*.rrd")) == [spawned]  # nothing saved besides


def test_frames_are_streamed_one_at_a_time(ds, rr, tmp_path, monkeypatch):
    """However long the episode, a stream's frames are decoded as they are logged, not all first."""
    from rio.recording.dataset import Episode
    from rio.recording.view import view_episode
    from rio.viz import RerunViz

    decoded, ahead = Counter(), []
    frames = Episode.frames

    def counted(self, camera, kind="rgb"):
        for f in frames(self, camera, kind):
            decoded[camera, kind] += 1
            yield f

    image = RerunViz.image

    def logged(self, path, rgb, jpeg_quality=None):
        logged.n[path] += 1
        ahead.append(decoded[tuple(path.split("/")[1:])] - logged.n[path])
        image(self, path, rgb, jpeg_quality)

    logged.n = Counter()
    monkeypatch.setattr(Episode, "frames", counted)
    monkeypatch.setattr(RerunViz, "image", logged)
    view_episode(ds, 0, save=tmp_path / "x.rrd")
    assert len(ahead) == 2 * STEPS and max(ahead) <= 1  # at most the next frame waits


def test_bad_episode_and_missing_dataset_are_one_line(ds, rr, tmp_path, capsys):
    assert rio_main(["datasets", "view", str(ds), "--episode", "7", "--save", str(tmp_path / "x.rrd")]) == 1
    assert "no episode 7" in _one_line_error(capsys)
    assert rio_main(["datasets", "view", str(tmp_path / "nothing"), "--save", str(tmp_path / "x.rrd")]) == 1
    assert "no dataset" in _one_line_error(capsys)
    assert not (tmp_path / "x.rrd").exists()


def test_a_damaged_episode_is_refused_unless_allowed(ds, rr, tmp_path, capsys):
    steps = ds / "episode_000001" / L.STEPS
    steps.write_bytes(bytes(steps.stat().st_size))
    out = tmp_path / "x.rrd"
    assert rio_main(["datasets", "view", str(ds), "-e", "1", "--save", str(out)]) == 1
    line = _one_line_error(capsys)
    assert "episode_000001: damaged episode" in line and "--allow-damaged" in line
    assert not out.exists()  # refused before anything was written
    assert rio_main(["datasets", "view", str(ds), "-e", "1", "--save", str(out), "--allow-damaged"]) == 0
    err = capsys.readouterr().err
    assert "warning:" in err and "damaged episode used anyway" in err
    assert _read(rr, out)[0]["/joints/arm.0/state"] == STEPS


def test_a_damaged_video_used_anyway_shows_the_rest(ds, rr, tmp_path, capsys):
    (ds / "episode_000000" / L.video_file("front", "rgb")).write_bytes(b"not a video")
    out = tmp_path / "x.rrd"
    assert rio_main(["datasets", "view", str(ds), "--save", str(out), "--allow-damaged"]) == 0
    assert "front.rgb: stops at frame 0" in capsys.readouterr().err
    temporal, _, _ = _read(rr, out)
    assert temporal["/cameras/front/rgb"] == 0 and temporal["/cameras/wrist/rgb"] == STEPS


def test_without_rerun_one_line_says_how_to_install(ds, tmp_path, monkeypatch, capsys):
    block_import(monkeypatch, "rerun")
    assert rio_main(["datasets", "view", str(ds), "--save", str(tmp_path / "x.rrd")]) == 1
    assert "pip install rerun-sdk" in _one_line_error(capsys)
    assert not (tmp_path / "x.rrd").exists()
