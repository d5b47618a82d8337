"""A wrench sensor's samples (`meta.sensors.<name>.force` / `.torque`, as the recorder writes a wrench-kind
sensor: `rio.interfaces.WrenchNode`) are exported by every format as one 6-value field `wrench_<name>`
(fx, fy, fz N; tx, ty, tz N m), step for step with the observation: LeRobot's `observation.wrench_<name>`
(named, also without the extra observations), Zarr's `data/wrench_<name>`, HDF5's
`observations/wrench_<name>` (ALOHA) and `obs/wrench_<name>` (robomimic); and imported back into the
sensor's own columns."""

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

NAMES = ["fx", "fy", "fz", "tx", "ty", "tz"]


def _wrench(i: int, episode: int) -> tuple[np.ndarray, np.ndarray]:
    """The tool pressing down harder every step, a twist about z growing with it."""
    return np.array([0.1, -0.2, -1.0 - 0.5 * i - 10 * episode]), np.array([0.01, 0.0, 0.002 * i])


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    root = tmp_path_factory.mktemp("wrench") / "ds"
    with Recorder(root, fps=30) as rec:
        for e in range(2):
            t0 = clock.now()
            for i in range(20):
                step = synthetic_step(i, t0 + i / 30)
                force, torque = _wrench(i, e)
                step.meta["sensors"] = {"ft": {"force": force, "torque": torque, "timestamp": t0 + i / 30}}
                rec.add(step)
            rec.keep()
    return root


def _expected(k: int) -> np.ndarray:
    return np.array([np.concatenate(_wrench(i, k)) for i in range(20)])


def _check_imported(back, exact: bool = True) -> None:
    for k, ep in enumerate(Dataset(back)):
        got = np.concatenate([ep.column("meta.sensors.ft.force"), ep.column("meta.sensors.ft.torque")], axis=1)
        want = _expected(k) if exact else _expected(k).astype(np.float32).astype(np.float64)
        np.testing.assert_array_equal(got, want)


def test_the_native_episode_records_force_and_torque(native):
    ep = Dataset(native).episode(1)
    assert ep.column("meta.sensors.ft.force").shape == (20, 3)
    np.testing.assert_array_equal(ep.column("meta.sensors.ft.torque"), _expected(1)[:, 3:])


@pytest.mark.parametrize("extra", [True, False])
def test_lerobot_writes_the_wrench(native, tmp_path, extra):
    out = tmp_path / "lr"
    get_format("lerobot", {"codec": "h264", "extra_observations": extra}).export(Dataset(native), out)
    info = json.loads((out / "meta/info.json").read_text())
    assert info["features"]["observation.wrench_ft"] == {"dtype": "float32", "shape": [6], "names": NAMES}
    got = np.asarray(pq.read_table(out / "data/chunk-000/file-000.parquet").column("observation.wrench_ft")
                     .to_pylist(), dtype=np.float32)
    np.testing.assert_array_equal(got, np.concatenate([_expected(0), _expected(1)]).astype(np.float32))
    get_format("lerobot").import_(out, tmp_path / "back")
    _check_imported(tmp_path / "back", exact=False)


def test_zarr_writes_the_wrench(native, tmp_path):
    zarr = pytest.importorskip("zarr")
    out = tmp_path / "r.zarr"
    get_format("zarr").export(Dataset(native), out)
    a = zarr.open_group(str(out), mode="r")["data/wrench_ft"]
    np.testing.assert_array_equal(a[:], np.concatenate([_expected(0), _expected(1)]))
    get_format("zarr").import_(out, tmp_path / "back")
    _check_imported(tmp_path / "back")


@pytest.mark.parametrize(("style", "key"), [("aloha", "observations/wrench_ft"), ("robomimic", "obs/wrench_ft")])
def test_hdf5_writes_the_wrench(native, tmp_path, style, key):
    out = tmp_path / ("aloha" if style == "aloha" else "demo.hdf5")
    get_format("hdf5", {"style": style}).export(Dataset(native), out)
    for k in range(2):
        path, group = (out / f"episode_{k}.hdf5", "") if style == "aloha" else (out, f"data/demo_{k}/")
        with h5py.File(path) as f:
            np.testing.assert_array_equal(f[group + key][()], _expected(k))
    get_format("hdf5", {"style": style}).import_(out, tmp_path / "back")
    _check_imported(tmp_path / "back")


def test_rlds_takes_the_force_and_torque_as_a_wrench(native):
    """Without TensorFlow here: the columns the RLDS export writes as `observation/wrench` and their values
    (`test_rlds.py` writes the files where the extra is installed)."""
    from rio_datasets.rlds_format import _wrench_key, wrench_columns, wrench_values

    ep = Dataset(native).episode(1)
    cols = wrench_columns(ep)
    assert cols == ["meta.sensors.ft.wrench"] and _wrench_key(cols[0], cols) == "wrench"
    np.testing.assert_array_equal(wrench_values(ep, cols[0]), _expected(1))
