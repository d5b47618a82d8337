"""The whole data loop on the default simulated station, through the real command line:
`rio teleop --record` writes an episode, and replaying it on the sim reproduces the trajectory.
(Issue: recording and datasets. Needs rio-sim, i.e. MuJoCo; skipped when it is not installed.)"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("rio_sim")
pytest.importorskip("mujoco")

from rio_sim.gl import OFFSCREEN_GL  # noqa: E402

from rio.recording.dataset import Dataset  # noqa: E402
from rio.testing import skip_tests_without  # noqa: E402
from rio.workflows.replay import replay_episode  # noqa: E402

pytestmark = pytest.mark.slow  # every test here runs for tens of seconds (a module fixture builds, installs or records)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "pick"
    cmd = [sys.executable, "-m", "rio", "teleop", "sim-so100", "--teleop", "scripted", "--duration", "6",
           "--record", str(root), "--on-end", "keep", "--instruction", "pick up the cube"]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=240, stdin=subprocess.DEVNULL)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "1 episode(s) kept" in out.stdout
    return root


def test_recording_holds_steps_cameras_and_metadata(recorded):
    ds = Dataset(recorded)
    assert len(ds) == 1
    ep = ds.episode(0)
    assert ep.meta["embodiment"] == "single_arm" and ep.instruction == "pick up the cube"
    assert set(ep.cameras) >= {"front", "wrist"}
    t = ep.column("t")
    assert len(t) >= 0.8 * 6 * ep.fps  # the control rate was held
    period = np.median(np.diff(t))
    assert abs(period - 1 / ep.fps) < 0.1 / ep.fps  # declared fps matches the data
    frame = next(iter(ep.frames("wrist")))
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    assert not ep.verify()  # every file matches its recorded size and hash


def test_the_recorded_frames_are_rendered_pictures(recorded):
    skip_tests_without(OFFSCREEN_GL)  # without OpenGL the cameras record flat placeholder frames
    frame = next(iter(Dataset(recorded).episode(0).frames("wrist")))
    assert frame.std() > 1.0


def test_replay_on_the_sim_reproduces_the_trajectory(recorded):
    ep = Dataset(recorded).episode(0)
    t_rec = ep.column("t") - ep.column("t")[0]
    q_rec = ep.column("obs.proprio")
    seen: list[tuple[float, np.ndarray]] = []
    summary = replay_episode(recorded, 0, "sim-so100", on_tick=lambda tick: seen.append(
        (tick.step.meta["t_obs"], np.asarray(tick.step.observation.proprio))), log=None)
    # one tick per recorded action, give or take the one the recording's own timing jitter adds or a late tick skips
    assert abs(summary.ticks - len(t_rec)) <= 1 or summary.overruns, summary.format()
    assert abs(summary.seconds - summary.details["recorded_seconds"]) < 0.5
    t_rep = np.array([s[0] for s in seen]) - seen[0][0]
    q_rep = np.stack([s[1] for s in seen])
    mid = (t_rep > 0.3) & (t_rep < t_rec[-1] - 0.3)
    for j in range(q_rec.shape[1]):
        err = np.abs(q_rep[mid, j] - np.interp(t_rep[mid], t_rec, q_rec[:, j]))
        assert np.median(err) < 0.02 and err.max() < 0.1, (j, float(np.median(err)), float(err.max()))
    np.testing.assert_allclose(q_rep[-1], q_rec[-1], atol=0.03)  # ends where the recording ended
