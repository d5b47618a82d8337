"""On a real SO-100/SO-101 arm. Skipped by default (marker `hardware`); run with the arm plugged in:

    RIO_SO100_PORT=/dev/ttyACM0 pytest plugins/rio-so100 -m hardware
    # optional: RIO_SO100_ROLE=leader, RIO_SO100_MODEL=so101, RIO_SO100_CALIBRATION=left,
    #           RIO_SO100_ALLOW_MOTION=1 to let the follower move its wrist roll by 0.15 rad and back

Read-only unless motion is allowed. Uses the user's real calibration directory (not a temp one).
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from rio.testing import lifecycle

pytestmark = pytest.mark.hardware

PORT = os.environ.get("RIO_SO100_PORT")
ROLE = os.environ.get("RIO_SO100_ROLE", "follower")
MODEL = os.environ.get("RIO_SO100_MODEL", "so100")
CALIBRATION = os.environ.get("RIO_SO100_CALIBRATION", "default")


@pytest.fixture(autouse=True)
def config_home():
    """Overrides the suite's temporary config directory: a real arm uses its real calibration."""
    if not PORT:
        pytest.skip("set RIO_SO100_PORT to the arm's serial port to run hardware tests")


def _have_calibration() -> bool:
    from rio_so100.calibration import calibration_path

    return calibration_path(CALIBRATION, MODEL, ROLE).is_file()


def test_all_six_servos_answer_and_sync_read_rate():
    from rio_so100.connection import check_present
    from rio_so100.feetech import control_table as T
    from rio_so100.feetech.bus import FeetechBus

    with FeetechBus(PORT) as bus:
        check_present(bus, range(1, 7))
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < 1.0:
            _, errors = bus.sync_read(range(1, 7), *T.STATE_BLOCK)
            n += 1
        print(f"real bus {PORT}: {n / (time.perf_counter() - t0):.0f} sync reads of 6 servos per second, "
              f"{bus.retried} retries, error bits {errors}")
        assert not any(errors.values()), errors


def test_node_reads_calibrated_joints_within_limits():
    if not _have_calibration():
        pytest.skip(f"no calibration '{CALIBRATION}' for the {MODEL} {ROLE}: run rio so100 calibrate first")
    from rio_so100.follower.driver import So100Follower
    from rio_so100.leader.driver import So100Leader

    cls = So100Follower if ROLE == "follower" else So100Leader
    with lifecycle(cls(port=PORT, calibration=CALIBRATION, model=MODEL)) as node:
        s = node.cycle()
        print("joint_pos", np.round(s["joint_pos"], 3), "error", s["error"])
        assert not np.any(s["error"])
        if ROLE == "follower":
            lower, upper = (np.array(x) for x in node.joint_limits())
            assert np.all(s["joint_pos"] >= lower - 0.05) and np.all(s["joint_pos"] <= upper + 0.05)
            assert s["enabled"]


def test_follower_small_wrist_roll_motion():
    if ROLE != "follower" or os.environ.get("RIO_SO100_ALLOW_MOTION") != "1" or not _have_calibration():
        pytest.skip("needs RIO_SO100_ALLOW_MOTION=1 and a calibrated follower")
    from rio_so100.follower.driver import So100Follower

    from rio import clock

    with lifecycle(So100Follower(port=PORT, calibration=CALIBRATION, model=MODEL)) as node:
        q0 = node.cycle()["joint_pos"].copy()
        for delta in (0.15, 0.0):
            target = q0.copy()
            target[4] += delta
            node.command_joints(target, clock.now() + 1.0)
            t_end = clock.now() + 1.5
            while clock.now() < t_end:
                s = node.cycle()
                time.sleep(0.01)
            assert abs(s["joint_pos"][4] - target[4]) < 0.03, s["joint_pos"]
