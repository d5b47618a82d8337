"""Datasets recorded before Core v3 named the gripper's opening `obs.gripper_position` (`gripper1_position`,
`gripper2_position` in a bimanual one). They still open, replay and merge: their columns read under today's
names (`rio.recording.dataset.current_names`), their files untouched. The export side is in rio-datasets'
tests (test_old_names.py)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

import rio.config
from rio import clock
from rio.recording import Dataset, Recorder
from rio.recording import merge as M
from rio.recording import paths as L
from rio.schema import BimanualObs, SingleArmObs, Step
from rio.testing import with_old_field_names
from rio.workflows.replay import replay_episode

FPS = 50.0
STEPS = 25
STATION = """
name = "old-names"
rate_hz = 50
[middleware]
name = "thread"
[components.arm]
driver = "rio.fake_arm"
dof = 3
[components.gripper]
driver = "rio.fake_gripper"
"""


def _action(i: int) -> np.ndarray:
    return np.array([0.02 * i, -0.01 * i, 0.3, 0.06 - 0.001 * i])  # 3 joints, then the opening (m)


def _record(root, *, bimanual: bool = False) -> None:
    with Recorder(root, fps=FPS) as rec:
        rec.info["embodiment"] = "bimanual" if bimanual else "single_arm"
        t0 = clock.now()
        for i in range(STEPS):
            a = _action(i)
            if bimanual:
                obs = BimanualObs(proprio=np.concatenate([a, a]), gripper1_width=float(a[3]),
                                  gripper2_width=float(a[3]) / 2)
                rec.add(Step(i, obs, None, np.concatenate([a, a]), {"t_obs": t0 + i / FPS}))
            else:
                obs = SingleArmObs(proprio=a.copy(), proprio_joints=a[:3].copy(), gripper_width=float(a[3]))
                rec.add(Step(i, obs, None, a, {"t_obs": t0 + i / FPS}))
        rec.keep()


def _layout(root) -> set[str]:
    """The column names the episodes' steps.json hold on disk (what a reader is given, before any mapping)."""
    files = sorted(root.glob(f"*/{L.STEPS_SCHEMA}"))
    assert files
    return {f[0] for path in files for f in json.loads(path.read_text())["fields"]}


@pytest.fixture
def datasets(tmp_path):
    """{"new": recorded today, "old": the same recording with the names it would have had before}."""
    _record(tmp_path / "new")
    shutil.copytree(tmp_path / "new", tmp_path / "old")
    with_old_field_names(tmp_path / "old")
    assert "obs.gripper_position" in _layout(tmp_path / "old") and "obs.gripper_width" not in _layout(tmp_path / "old")
    return {"new": tmp_path / "new", "old": tmp_path / "old"}


def test_an_old_dataset_reads_under_the_new_name(datasets):
    old, new = Dataset(datasets["old"]).episode(0), Dataset(datasets["new"]).episode(0)
    assert old.verify() == []  # its files are as recorded: checksums hold
    assert "obs.gripper_width" in old.schema.names and "obs.gripper_position" not in old.schema.names
    np.testing.assert_array_equal(old.column("obs.gripper_width"), new.column("obs.gripper_width"))
    np.testing.assert_array_equal(old.observation_columns()["gripper_width"], [_action(i)[3] for i in range(STEPS)])
    widths = [s.observation.gripper_width for s in old.steps()]
    assert widths == pytest.approx([_action(i)[3] for i in range(STEPS)])
    assert "obs.gripper_position" in _layout(datasets["old"])  # read, not rewritten


def test_an_old_bimanual_dataset_reads_both_grippers(tmp_path):
    _record(tmp_path / "ds", bimanual=True)
    with_old_field_names(tmp_path / "ds")
    assert {"obs.gripper1_position", "obs.gripper2_position"} <= set(_layout(tmp_path / "ds"))
    step = next(Dataset(tmp_path / "ds").episode(0).steps())
    assert isinstance(step.observation, BimanualObs)
    assert (step.observation.gripper1_width, step.observation.gripper2_width) == (0.06, 0.03)


def test_an_old_dataset_replays(datasets, tmp_path):
    (tmp_path / "st.toml").write_text(STATION)
    s = replay_episode(datasets["old"], 0, str(tmp_path / "st.toml"), approach_s=0.2, log=None)
    assert s.reason == "the episode ended", s.format()
    assert s.arms[0].gripper == pytest.approx(_action(STEPS - 1)[3], abs=2e-3), s.format()  # the fake's opening


def test_an_old_and_a_new_dataset_merge(datasets, tmp_path):
    out = tmp_path / "merged"
    M.merge_datasets([datasets["old"], datasets["new"]], out)
    assert "obs.gripper_position" not in _layout(out) and "obs.gripper_width" in _layout(out)
    eps = list(Dataset(out))
    assert len(eps) == 2 and all(e.verify() == [] for e in eps)
    for ep in eps:
        np.testing.assert_array_equal(ep.column("obs.gripper_width"), [_action(i)[3] for i in range(STEPS)])


def test_a_script_reading_the_old_field_gets_the_new_one_with_a_notice(caplog, monkeypatch):
    monkeypatch.setattr(rio.config, "_noticed", set())  # the notice is once per process: start afresh
    obs = SingleArmObs(proprio=np.zeros(4), gripper_width=0.03)
    with caplog.at_level("WARNING", logger="rio.config"):
        assert obs.gripper_position == 0.03 and obs.gripper_position == 0.03
    assert [r.getMessage() for r in caplog.records] == [
        "SingleArmObs: 'gripper_position' is now 'gripper_width' (the old name is accepted until the next release)"]
    with pytest.raises(AttributeError, match="no attribute 'gripper_opening'"):
        obs.gripper_opening  # noqa: B018 -- any other missing name stays an AttributeError
