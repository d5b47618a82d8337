"""A recording session on the default simulated station: three episodes in one station session (the nodes keep
their processes), each scene reset through `Env.reset` to its own seeded start, the kept episodes numbered
0, 1, 2, and no end-of-run hold warning from the nodes. (Needs rio-sim, i.e. MuJoCo.)"""

from __future__ import annotations

import re

import pytest

pytest.importorskip("rio_sim")
pytest.importorskip("mujoco")

from rio.recording import Dataset, Recorder, station_depth  # noqa: E402
from rio.station.load import load_station  # noqa: E402
from rio.workflows.teleop import record_teleop  # noqa: E402


def test_three_episodes_in_one_station_session(tmp_path, capfd):
    root = tmp_path / "pick"
    sessions, pids, said = [], [], []

    def decide(summary, rec, stop):
        pids.append(dict(sessions[0].manager.pids()))
        assert not summary.signal and summary.ticks > 10  # a real run each time, not one ended at its start
        return "keep", True

    st = load_station("sim-so100")
    with Recorder(root, fps=st.rate_hz, station=st.name, episodes=3, cameras=st.has_cameras,
                  depth=station_depth(st)) as rec:
        record_teleop(st, rec, decide, "scripted", duration=2.0, reset_s=0.5, log=said.append,
                      on_start=sessions.append)
    assert len(pids) == 3 and len(pids[0]) >= 4  # arm, gripper, world, cameras, teleop: processes
    assert pids[0] == pids[1] == pids[2]  # the same processes served every episode
    assert sum("starting station" in line for line in said) == 1
    ds = Dataset(root)
    assert [e["index"] for e in ds.episodes] == [0, 1, 2]
    tasks = [ds.episode(k).meta["metadata"]["task"] for k in range(3)]
    assert [t["episode"] for t in tasks] == [0, 1, 2]  # each scene reset to its own episode's start
    assert len({tuple(t["start"]["cube"]) for t in tasks}) == 3
    # the nodes printed no hold for the end of a run (a stall mid-run on a loaded machine still may: mid-move)
    holds = [ln for ln in capfd.readouterr().err.splitlines() if re.search("stream of commands stopped", ln)]
    assert all("mid-move" in ln for ln in holds), holds
