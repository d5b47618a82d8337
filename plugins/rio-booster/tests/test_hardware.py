"""On a real T1. Skipped by default (marker `hardware`); run with this machine on the robot's network:

    RIO_T1_INTERFACE=192.168.10.10 pytest plugins/rio-booster -m hardware

Read-only: it subscribes to rt/low_state with the SDK and never publishes a command nor changes a mode
(the robot does not move)."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest

pytestmark = pytest.mark.hardware

INTERFACE = os.environ.get("RIO_T1_INTERFACE")


def test_the_robots_low_state_is_sane():
    if not INTERFACE:
        pytest.skip("set RIO_T1_INTERFACE (this computer's interface on the T1's network, name or address)")
    sdk = pytest.importorskip("booster_robotics_sdk_python")
    from rio_booster.t1 import JOINTS

    from rio.interfaces.damping import tilt_from_rpy as tilt_deg

    sdk.ChannelFactory.Instance().Init(int(os.environ.get("RIO_T1_DOMAIN_ID", "0")), INTERFACE)
    got, lock = [], threading.Lock()

    def on_state(msg):
        s = ([m.q for m in msg.motor_state_serial], list(msg.imu_state.rpy), list(msg.imu_state.gyro))
        with lock:
            got.append(s)

    sub = sdk.B1LowStateSubscriber(on_state)
    sub.InitChannel()
    try:
        time.sleep(1.0)
    finally:
        sub.CloseChannel()
    assert len(got) > 100, f"{len(got)} low states in 1 s"
    q, rpy, gyro = (np.asarray(x, np.float64) for x in got[-1])
    assert q.shape == (23,), f"{q.shape[0]} serial joints: not a 23-DoF T1"
    lower, upper = np.array([j.lower for j in JOINTS]), np.array([j.upper for j in JOINTS])
    assert np.isfinite(q).all() and np.all((q > lower - 0.1) & (q < upper + 0.1)), q
    assert np.isfinite(tilt_deg(rpy)) and np.all(np.abs(gyro) < 10.0)
