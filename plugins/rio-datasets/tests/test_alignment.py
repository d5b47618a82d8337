"""Exported observations and actions are paired the way trainers read them: action[t] is the command issued
after observation[t] was read. Checked on a motion whose truth is known: a controller commanding a joint at
constant velocity, c_k = V * k * dt at tick k, on the real control loop recording a fake station; it logs
the observation each command was decided on, so every exported pair is checked against what happened."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from rio.recording import Dataset
from rio.recording.format import get_format
from rio.workflows.run import run_workflow

STATION = """
name = "align"
rate_hz = 30
[middleware]
name = "thread"
[components.arm]
driver = "rio.fake_arm"
dof = 3
[components.gripper]
driver = "rio.fake_gripper"
"""
V = 0.3  # rad/s


class ConstantVelocity:
    """Joint 1 at constant velocity; remembers, for every command, the time of the observation it saw."""

    name = "constant_velocity"

    def __init__(self) -> None:
        self.seen: list[tuple[float, np.ndarray]] = []

    def reset(self, loop) -> None:
        self.k, self.dt = 0, loop.dt

    def step(self, tick) -> np.ndarray:
        command = np.array([V * self.k * self.dt, 0.0, 0.0, 0.02])
        self.seen.append((float(tick.obs.meta["t_obs"]), command))
        self.k += 1
        return command

    def done(self) -> None:
        return None


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("align")
    station = tmp / "align.toml"
    station.write_text(STATION)
    ctl = ConstantVelocity()
    run_workflow(str(station), lambda session: ctl, record=str(tmp / "ds"), duration=1.5, log=None)
    return tmp / "ds", ctl


def _truth(root, ctl) -> tuple[np.ndarray, np.ndarray]:
    """(observation.state, the command issued after each observation), from the recording and the log."""
    ep = Dataset(root).episode(0)
    after = {t_obs: command for t_obs, command in ctl.seen}
    t = ep.column("t")
    commands = [after.get(float(ti)) for ti in t]
    assert all(c is not None for c in commands[:-1])  # every observation but the last had a command after it
    commands[-1] = ep.column("action")[-1]  # after the last: none; the robot holds the last command
    return ep.column("obs.proprio"), np.stack(commands)


def test_the_native_record_pairs_each_observation_with_the_command_sent_before_it(recorded):
    root, ctl = recorded
    ep = Dataset(root).episode(0)
    actions, n = ep.column("action"), len(ep)
    assert n > 30
    np.testing.assert_allclose(actions[:, 0], V * np.arange(n) / 30, atol=1e-12)  # c_k at row k
    _, after = _truth(root, ctl)
    np.testing.assert_allclose(after[:-1, 0], V * np.arange(1, n) / 30, atol=1e-12)  # c_(k+1) came after o_k


def _check(state: np.ndarray, action: np.ndarray, root, ctl) -> None:
    obs, after = _truth(root, ctl)
    np.testing.assert_allclose(state, obs, atol=1e-6)
    np.testing.assert_allclose(action, after, atol=1e-6)
    n = len(action)
    np.testing.assert_allclose(action[:-1, 0], V * np.arange(1, n) / 30, atol=1e-6)  # c_(t+1) at frame t
    assert (np.diff(state[:, 0]) >= 0).all() and state[-1, 0] > 0.5 * V  # the arm followed the motion


def test_lerobot_pairs_each_observation_with_the_command_after_it(recorded, tmp_path):
    root, ctl = recorded
    get_format("lerobot", {"codec": "h264"}).export(Dataset(root), tmp_path / "lr")
    data = pq.read_table(tmp_path / "lr/data/chunk-000/file-000.parquet")
    _check(np.asarray(data.column("observation.state").to_pylist()), np.asarray(data.column("action").to_pylist()),
           root, ctl)
    rio = json.loads((tmp_path / "lr/meta/rio.json").read_text())
    assert rio["episodes"][0]["actions"] == "action[t] is the command issued after observation[t]"


def test_zarr_pairs_each_observation_with_the_command_after_it(recorded, tmp_path):
    zarr = pytest.importorskip("zarr")
    root, ctl = recorded
    get_format("zarr").export(Dataset(root), tmp_path / "r.zarr")
    z = zarr.open_group(str(tmp_path / "r.zarr"), mode="r")
    _check(z["data/state"][:], z["data/action"][:], root, ctl)


@pytest.mark.parametrize("style", ["aloha", "robomimic"])
def test_hdf5_pairs_each_observation_with_the_command_after_it(recorded, tmp_path, style):
    root, ctl = recorded
    out = tmp_path / ("aloha" if style == "aloha" else "demo.hdf5")
    get_format("hdf5", {"style": style}).export(Dataset(root), out)
    with h5py.File(out / "episode_0.hdf5" if style == "aloha" else out) as f:
        g = f if style == "aloha" else f["data/demo_0"]
        state = g["observations/qpos" if style == "aloha" else "obs/state"][()]
        _check(state, g["action" if style == "aloha" else "actions"][()], root, ctl)


def test_an_import_pairs_them_back_the_native_way(recorded, tmp_path):
    root, _ = recorded
    get_format("hdf5").export(Dataset(root), tmp_path / "aloha")
    get_format("hdf5").import_(tmp_path / "aloha", tmp_path / "back")
    np.testing.assert_array_equal(Dataset(tmp_path / "back").episode(0).column("action"),
                                  Dataset(root).episode(0).column("action"))
