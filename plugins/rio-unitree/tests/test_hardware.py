"""On a real G1. Skipped by default (marker `hardware`); run with this machine on the robot's network:

    RIO_G1_INTERFACE=eth0 pytest plugins/rio-unitree -m hardware

Read-only: it listens to rt/lowstate and never publishes a command (the robot does not move)."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

pytestmark = pytest.mark.hardware

INTERFACE = os.environ.get("RIO_G1_INTERFACE")


def test_the_robots_lowstate_is_sane():
    if not INTERFACE:
        pytest.skip("set RIO_G1_INTERFACE (the interface on the G1's network, 192.168.123.x)")
    from rio_unitree.dds import LOWSTATE, Participant
    from rio_unitree.g1 import JOINTS
    from rio_unitree.tools import check
    from rio_unitree.wire import LowState, state_crc_ok

    from rio.interfaces.damping import tilt_from_quat as tilt_deg

    report = check(INTERFACE, timeout_s=5.0)
    assert report.ok, report.problem
    with Participant(int(os.environ.get("RIO_G1_DOMAIN_ID", "0")), INTERFACE) as p:
        reader = p.reader(LOWSTATE, depth=64)
        samples, t_end = [], time.monotonic() + 1.0
        while time.monotonic() < t_end:
            samples += reader.take()
            time.sleep(0.002)
        assert len(samples) > 100, f"{len(samples)} lowstate messages in 1 s (the robot sends 500 Hz)"
        assert all(state_crc_ok(d) for d in samples)
        s = LowState.decode(samples[-1])
    q = s.q[[j.slot for j in JOINTS]]
    lower, upper = np.array([j.lower for j in JOINTS]), np.array([j.upper for j in JOINTS])
    assert np.isfinite(q).all() and np.all((q > lower - 0.1) & (q < upper + 0.1)), q
    assert abs(np.linalg.norm(s.quaternion) - 1.0) < 0.01 and np.isfinite(tilt_deg(s.quaternion))
    assert np.all(np.abs(s.gyroscope) < 10.0)
