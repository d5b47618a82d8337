"""`rio replay` on the thread middleware with the core's fake arm: actions are sent at the recorded
rate, the arm ends where the recording ended, and a different morphology is refused."""

from __future__ import annotations

import numpy as np
import pytest

from rio import clock
from rio.errors import RioError
from rio.recording import Recorder
from rio.schema import SingleArmObs, Step
from rio.workflows.replay import replay_episode

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


def test_replay_refuses_a_damaged_episode_before_the_robot_moves(tmp_path, monkeypatch):
    """An all-zero steps.bin (fails its recorded sha256) must never be sent to a robot as zero actions."""
    import rio.workflows.run as workflow
    from rio.recording import DamagedEpisode, DamagedEpisodeWarning

    (tmp_path / "st.toml").write_text(STATION)
    _record(tmp_path / "ds")
    steps = tmp_path / "ds" / "episode_000000" / "steps.bin"
    steps.write_bytes(bytes(steps.stat().st_size))
    started = []
    monkeypatch.setattr(workflow, "run_workflow", lambda *a, **k: started.append(a))
    with pytest.raises(DamagedEpisode, match=r"episode_000000.*steps\.bin: changed since it was recorded"):
        replay_episode(tmp_path / "ds", 0, str(tmp_path / "st.toml"), approach_s=0, log=None)
    assert not started
    with pytest.warns(DamagedEpisodeWarning, match="steps.bin"):  # allowed: used anyway, with a warning
        replay_episode(tmp_path / "ds", 0, str(tmp_path / "st.toml"), approach_s=0, log=None, allow_damaged=True)
    assert len(started) == 1


@pytest.mark.parametrize("args,why,code", [(["--speed", "0"], "'--speed': must be a finite number > 0", 2),
                                           (["--speed", "-2"], "'--speed'", 2), (["--speed", "nan"], "'--speed'", 2),
                                           (["--approach", "-1"], "'--approach': must be a finite number >= 0", 2),
                                           (["--episode", "7"], "no episode 7", 1)])
def test_replay_bad_arguments_are_one_line(tmp_path, capsys, args, why, code):
    """Bad values are usage errors (2) naming the option, refused before anything opens; a missing
    episode is found in the dataset (1)."""
    from rio.cli import main as rio_main

    (tmp_path / "st.toml").write_text(STATION)
    _record(tmp_path / "ds", n=5)
    assert rio_main(["replay", str(tmp_path / "ds"), "-s", str(tmp_path / "st.toml"), *args]) == code
    err = capsys.readouterr().err
    assert why in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err


def test_replay_of_a_damaged_episode_is_one_line_in_the_cli(tmp_path, capsys):
    from rio.cli import main as rio_main

    (tmp_path / "st.toml").write_text(STATION)
    _record(tmp_path / "ds", n=5)
    steps = tmp_path / "ds" / "episode_000000" / "steps.bin"
    steps.write_bytes(bytes(steps.stat().st_size))
    assert rio_main(["replay", str(tmp_path / "ds"), "-s", str(tmp_path / "st.toml")]) == 1
    err = " ".join(capsys.readouterr().err.split())
    assert "episode_000000: damaged episode: steps.bin: changed since it was recorded" in err
    assert "--allow-damaged" in err and "Traceback" not in err
