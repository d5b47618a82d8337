"""`rio replay` on the thread middleware with the core's fake arm: actions are sent at the recorded
rate, the arm ends where the recording ended, and a different morphology is refused."""

from __future__ import annotations

import numpy as np
import pytest
from rio import clock
from rio.errors import RioError
from rio.recording import Recorder, replay_episode
from rio.schema import SingleArmObs, Step

STATION = """
name = "replay-test"
rate_hz = 50
[middleware]
name = "thread"
[components.arm]
driver = "rio.fake_arm"
dof = 3
[components.gripper]
driver = "rio.fake_gripper"
"""


def _record(root, n=25, fps=50.0, dim=4):
    with Recorder(root, fps=fps) as rec:
        rec.info["embodiment"] = "single_arm"
        t0 = clock.now()
        for i in range(n):
            a = np.array([0.02 * i, -0.01 * i, 0.3, 0.04])[:dim]
            rec.add(Step(i, SingleArmObs(proprio=a.copy()), None, a, {"t_obs": t0 + i / fps}))
        rec.keep()


def test_replay_on_fake_station(tmp_path):
    (tmp_path / "st.toml").write_text(STATION)
    _record(tmp_path / "ds")
    seen = []
    s = replay_episode(tmp_path / "ds", 0, str(tmp_path / "st.toml"), approach_s=0.2, log=None,
                       on_tick=lambda tick: seen.append(clock.now()))
    assert s.reason == "the episode ended" and (abs(s.ticks - 25) <= 1 or s.overruns), s.format()
    assert abs(s.seconds - 24 / 50) < 0.1  # at the recorded rate
    assert np.median(np.diff(seen)) == pytest.approx(1 / 50, abs=4e-3)
    assert s.arms[0].joint_err_rad is not None and s.arms[0].joint_err_rad[2] < 1e-6, s.format()


def test_replay_refuses_other_action_layout(tmp_path):
    (tmp_path / "st.toml").write_text(STATION)
    _record(tmp_path / "ds", dim=3)
    with pytest.raises(RioError, match="3 values"):
        replay_episode(tmp_path / "ds", 0, str(tmp_path / "st.toml"), approach_s=0, log=None)
