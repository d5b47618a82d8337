"""The environment state (a simulator's object poses, recorded under `meta.sensors.<name>.object_poses` and
named by the recorder) exported as LeRobot's `observation.environment_state`, Zarr's `data/environment_state`
and HDF5's `observations/environment_state` (ALOHA) / `obs/object` (robomimic), each with one name per
element, and imported back into the columns it came from."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from rio import clock
from rio.recording import Dataset, Recorder
from rio.recording.format import get_format
from rio.recording.synthetic import synthetic_step

OBJECTS = ["cube", "pad"]
NAMES = [f"{o}.{c}" for o in OBJECTS for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
COLUMN = "meta.sensors.world.object_poses"


class _World:
    """What the recorder reads of a world sensor's client: the names of its objects."""

    def object_names(self) -> list[str]:
        return list(OBJECTS)


class _Env:
    station, sensors = "synthetic", {"world": _World()}


def _poses(t: float) -> np.ndarray:
    """A cube sliding and turning next to a pad that stays put (unit quaternions)."""
    yaw = 0.3 * t
    return np.array([[0.2 + 0.01 * t, 0.05, 0.0125, np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)],
                     [0.2, -0.06, 0.001, 1.0, 0.0, 0.0, 0.0]])


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    root = tmp_path_factory.mktemp("env") / "ds"
    with Recorder(root, fps=30) as rec:
        rec.describe_env(_Env())
        for _ in range(2):
            t0 = clock.now()
            for i in range(20):
                t = t0 + i / 30
                step = synthetic_step(i, t)
                step.meta["sensors"] = {"world": {"object_poses": _poses(i / 30 + 3 * len(rec.kept))}}
                rec.add(step)
            rec.keep()
    return root


def test_the_recorder_names_the_environment_state(native):
    ep = Dataset(native).episode(0)
    assert ep.meta["environment_state"] == {COLUMN: NAMES}
    assert ep.column(COLUMN).shape == (20, 2, 7)


def _native_state(root) -> list[np.ndarray]:
    return [e.column(COLUMN).reshape(len(e), -1) for e in Dataset(root)]


def _check_imported(native, back, exact: bool = True) -> None:
    for e0, e1 in zip(Dataset(native), Dataset(back), strict=True):
        assert e1.meta["environment_state"] == {COLUMN: NAMES}
        x0, x1 = e0.column(COLUMN), e1.column(COLUMN)
        assert x1.shape == x0.shape and x1.dtype == np.float64
        np.testing.assert_array_equal(x1, x0 if exact else x0.astype(np.float32).astype(np.float64))


def test_lerobot_declares_and_writes_it(native, tmp_path):
    out = tmp_path / "lr"
    get_format("lerobot", {"codec": "h264"}).export(Dataset(native), out)
    info = json.loads((out / "meta/info.json").read_text())
    assert info["features"]["observation.environment_state"] == {"dtype": "float32", "shape": [14], "names": NAMES}
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    got = np.asarray(data.column("observation.environment_state").to_pylist(), dtype=np.float32)
    assert got.dtype == np.float32 and got.shape == (40, 14)
    np.testing.assert_array_equal(got, np.concatenate(_native_state(native)).astype(np.float32))
    stats = json.loads((out / "meta/stats.json").read_text())["observation.environment_state"]
    assert len(stats["mean"]) == 14 and stats["max"][0] == pytest.approx(float(got[:, 0].max()))
    rio = json.loads((out / "meta/rio.json").read_text())
    assert rio["episodes"][0]["environment_state"] == {COLUMN: {"names": NAMES, "shape": [2, 7]}}
    get_format("lerobot").import_(out, tmp_path / "back")
    _check_imported(native, tmp_path / "back", exact=False)


def test_lerobot_writes_it_even_without_the_extra_observations(native, tmp_path):
    out = tmp_path / "lr"
    get_format("lerobot", {"codec": "h264", "extra_observations": False}).export(Dataset(native), out)
    features = json.loads((out / "meta/info.json").read_text())["features"]
    assert "observation.environment_state" in features and "observation.proprio_eef" not in features


def test_zarr_writes_it_with_its_names(native, tmp_path):
    zarr = pytest.importorskip("zarr")
    out = tmp_path / "r.zarr"
    get_format("zarr").export(Dataset(native), out)
    root = zarr.open_group(str(out), mode="r")
    a = root["data/environment_state"]
    assert a.shape == (40, 14) and list(a.attrs["names"]) == NAMES
    np.testing.assert_array_equal(a[:], np.concatenate(_native_state(native)))
    get_format("zarr").import_(out, tmp_path / "back")
    _check_imported(native, tmp_path / "back")


@pytest.mark.parametrize(("style", "key"), [("aloha", "observations/environment_state"), ("robomimic", "obs/object")])
def test_hdf5_writes_it_with_its_names(native, tmp_path, style, key):
    out = tmp_path / ("aloha" if style == "aloha" else "demo.hdf5")
    get_format("hdf5", {"style": style}).export(Dataset(native), out)
    states = _native_state(native)
    for k in range(2):
        path, group = (out / f"episode_{k}.hdf5", "") if style == "aloha" else (out, f"data/demo_{k}/")
        with h5py.File(path) as f:
            d = f[group + key]
            assert json.loads(d.attrs["names"]) == NAMES
            np.testing.assert_array_equal(d[()], states[k])
    get_format("hdf5", {"style": style}).import_(out, tmp_path / "back")
    _check_imported(native, tmp_path / "back")
