"""Homing on the simulated SO-100: from a folded pose, every joint ends at its home pose within tolerance, no
joint moves faster than the homing speed allows, and `rio home` does the same from the command line without
asking (a sim station). (Needs rio-sim, i.e. MuJoCo.)"""

from __future__ import annotations

import subprocess
import sys
import threading

import numpy as np
import pytest

pytest.importorskip("rio_sim")
pytest.importorskip("mujoco")

from rio import clock  # noqa: E402
from rio.station.load import load_station  # noqa: E402
from rio.workflows.home import HOME_TOL, home_devices, is_stand_in  # noqa: E402
from rio.workflows.run import open_session  # noqa: E402

SPEED = 0.6  # rad/s


def _fold(arm) -> np.ndarray:
    """Send the arm towards its joint limits (a folded arm at rest), away from home; returns the pose reached."""
    lower, upper = (np.asarray(x) for x in arm.joint_limits())
    home = np.asarray(arm.home_pose())
    far = np.where(upper - home > home - lower, upper, lower)  # the farther limit of each joint
    folded = home + 0.8 * np.clip(far - home, -1.5, 1.5)
    arm.move_to(folded.tolist(), 1.5)
    clock.precise_wait(clock.now() + 3.0)
    return np.asarray(arm.get_state()["joint_pos"])


def test_homing_a_folded_arm_at_a_bounded_speed():
    st = load_station("sim-so100")
    assert is_stand_in(st)
    with open_session(st, log=None) as session:
        arm = session.env.robot.clients["arm"]
        start = _fold(arm)
        home = np.asarray(arm.home_pose())
        assert np.max(np.abs(start - home)) > 0.8  # really away from home
        samples, done = [], threading.Event()

        def watch():
            while not done.is_set():
                s = arm.get_state()
                samples.append((float(s["timestamp"]), np.asarray(s["joint_pos"], dtype=np.float64).copy()))
                clock.precise_wait(clock.now() + 0.02)

        t = threading.Thread(target=watch)
        t.start()
        try:
            result = home_devices(session.env.robot.clients, speed=SPEED)
        finally:
            done.set()
            t.join()
    assert result.arrived and result.error_rad["arm"] <= HOME_TOL, result.lines()
    assert result.seconds["arm"] == pytest.approx(np.max(np.abs(start - home)) / SPEED, rel=0.05)
    # the speed bound, measured over 0.2 s windows of the arm's own samples (sim tracking lag adds a little)
    ts = np.array([s[0] for s in samples])
    qs = np.array([s[1] for s in samples])
    fastest = 0.0
    for i in range(len(ts)):
        j = np.searchsorted(ts, ts[i] + 0.2)
        if j < len(ts) and ts[j] > ts[i]:
            fastest = max(fastest, float(np.max(np.abs(qs[j] - qs[i])) / (ts[j] - ts[i])))
    assert 0.5 * SPEED < fastest <= 1.25 * SPEED


def test_rio_home_on_a_sim_station_asks_nothing():
    out = subprocess.run([sys.executable, "-m", "rio", "home", "sim-so100", "--home-speed", "1.0"],
                         capture_output=True, text=True, timeout=240, stdin=subprocess.DEVNULL)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "arm: at its home pose" in out.stdout
