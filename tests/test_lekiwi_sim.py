"""LeKiwi in simulation, through the real command line: `rio teleop lekiwi-sim` with a scripted device in
base mode drives the three-wheel base (odometry against the simulated ground truth) and records the mobile
manipulator's episode; replaying it drives the base along the same path. (Needs rio-sim, i.e. MuJoCo.)"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("rio_sim")
pytest.importorskip("mujoco")

from rio.recording.dataset import Dataset  # noqa: E402
from rio.workflows.replay import replay_episode  # noqa: E402

#: forward 0.3 m in 4 s, then 0.2 m to the left in 3 s, then still (the script's moves are tool
#: displacements; in base mode x, y drive the base)
MOVES = [[0.3, 0.0, 0.0, 1.0, 4.0], [0.0, 0.2, 0.0, 1.0, 3.0], [0.0, 0.0, 0.0, 1.0, 0.5]]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "drive"
    cmd = [sys.executable, "-m", "rio", "teleop", "lekiwi-sim", "--teleop", "scripted", "--mode", "base",
           "--teleop-set", "script=moves", "--teleop-set", f"moves={json.dumps(MOVES)}", "--record", str(root),
           "--on-end", "keep", "--instruction", "drive to the cube"]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "1 episode(s) kept" in out.stdout and "base: odometry" in out.stdout, out.stdout[-2000:]
    return root


def test_the_base_drives_the_script_and_odometry_matches_the_sim(recorded):
    ep = Dataset(recorded).episode(0)
    assert ep.meta["embodiment"] == "mobile_manipulator"
    odom = ep.column("obs.base_odom")
    # the script's path: ahead, then to the left, without turning. How far depends on the machine: the device
    # commands speeds in wall time, a world that cannot keep up runs slower (rtf < 1) and goes less far.
    x, y = odom[-1, 0], odom[-1, 1]
    assert x > 0.1 and y > 0.04 and abs(odom[-1, 2]) < 0.05 and x < 0.33 and y < 0.23, odom[-1]
    ahead = int(np.argmax(odom[:, 0] > 0.9 * x))
    assert odom[ahead, 1] < 0.3 * y, (odom[ahead], odom[-1])  # first ahead, then left
    actions = ep.column("action")
    assert actions.shape[1] == 5 + 1 + 3 and np.abs(actions[:, -3:]).max() > 0.05  # the base was commanded
    q = ep.column("obs.proprio_joints")
    assert np.abs(q - q[0]).max() < 0.02  # the arm held while the keys drove the base


def test_replay_drives_the_base_along_the_recorded_path(recorded):
    ep = Dataset(recorded).episode(0)
    odom = ep.column("obs.base_odom")
    seen, truth = [], []

    def tick(t):
        seen.append(np.asarray(t.step.observation.base_odom))
        truth.append(np.asarray(t.env.robot.clients["base"].get_state()["true_pose"]))

    replay_episode(recorded, 0, "lekiwi-sim", log=None, on_tick=tick)
    end, recorded_end = seen[-1] - seen[0], odom[-1] - odom[0]
    # the same way (how far again depends on how fast the world runs, see above)
    cos = float(end[:2] @ recorded_end[:2]) / (np.linalg.norm(end[:2]) * np.linalg.norm(recorded_end[:2]))
    assert cos > 0.95 and 0.5 < np.linalg.norm(end[:2]) / np.linalg.norm(recorded_end[:2]) < 2.0, (end, recorded_end)
    # the odometry (wheel speeds through the omni kinematics, integrated) against the simulated pose
    moved = truth[-1] - truth[0]
    assert np.allclose(end, moved, atol=0.01), (end, moved)
