"""On a real GELLO. Skipped by default (marker `hardware`); run with the leader plugged in:

    RIO_GELLO_PORT=/dev/serial/by-id/usb-FTDI_... RIO_GELLO_LAYOUT=xarm7 pytest plugins/rio-teleop -m hardware
    # optional: RIO_GELLO_CALIBRATION=left (default: default), RIO_GELLO_BAUDRATE=1000000

Read-only: the joints stay torque-off. Uses the user's real calibration directory.
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from rio.testing import lifecycle

pytestmark = pytest.mark.hardware

PORT = os.environ.get("RIO_GELLO_PORT")
LAYOUT = os.environ.get("RIO_GELLO_LAYOUT", "xarm7")
CALIBRATION = os.environ.get("RIO_GELLO_CALIBRATION", "default")
BAUDRATE = int(os.environ.get("RIO_GELLO_BAUDRATE", "57600"))


@pytest.fixture(autouse=True)
def need_leader():
    if not PORT:
        pytest.skip("set RIO_GELLO_PORT (and RIO_GELLO_LAYOUT) to run against a real GELLO")


def test_every_servo_answers_and_is_an_x_series():
    from rio_teleop.gello import control_table as T
    from rio_teleop.gello.bus import DynamixelBus
    from rio_teleop.gello.layouts import get_layout

    lay = get_layout(LAYOUT)
    with DynamixelBus(PORT, baudrate=BAUDRATE, names=lay.servo_names()) as bus:
        models = bus.check_present(lay.ids)
    assert all(m in T.MODEL_NAMES for m in models.values()), models


def test_leader_reads_finite_joints_at_rate():
    from rio_teleop.gello.driver import GelloLeader

    node = GelloLeader(port=PORT, layout=LAYOUT, calibration=CALIBRATION, baudrate=BAUDRATE)
    node.setup()
    with lifecycle(node):
        t0, n = time.perf_counter(), 0
        while time.perf_counter() - t0 < 1.0:
            s = node.read_state()
            n += 1
    assert np.all(np.isfinite(s["joint_pos"])) and 0.0 <= s["gripper"] <= 1.0
    assert np.all(np.abs(s["joint_pos"]) < 2 * np.pi), s["joint_pos"]  # a calibrated leader reads follower angles
    assert n > (20 if BAUDRATE < 1_000_000 else 200), f"{n} reads in 1 s"
