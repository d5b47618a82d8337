"""On a real UFACTORY arm. Skipped by default (marker `hardware`); run with the controller reachable:

    RIO_XARM_IP=192.168.1.185 RIO_XARM_MODEL=xarm7 pytest plugins/rio-ufactory -m hardware
    # optional: RIO_XARM_ALLOW_MOTION=1 lets the arm move its last joint by 0.1 rad and back (clear the
    #           space around the tool first), RIO_XARM_GRIPPER=ufactory.gripper|ufactory.robotiq|... to
    #           open and close the gripper on the tool connector.

Read-only unless motion is allowed.
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from rio.testing import cycle_gripper, lifecycle, nudge_last_joint

pytestmark = pytest.mark.hardware

IP = os.environ.get("RIO_XARM_IP")
MODEL = os.environ.get("RIO_XARM_MODEL", "xarm7")
MOTION = os.environ.get("RIO_XARM_ALLOW_MOTION") == "1"
GRIPPER = os.environ.get("RIO_XARM_GRIPPER")


@pytest.fixture(autouse=True)
def need_ip():
    if not IP:
        pytest.skip("set RIO_XARM_IP (and RIO_XARM_MODEL) to run the xArm hardware tests")


def _node(driver: str, **fields):
    from rio.conformance.driving import build_node, resolve_driver

    return build_node(resolve_driver(driver), {"ip": IP, **fields}, "hw")


def test_identity_and_realtime_report_rate():
    from rio_ufactory.connection import XArmConnection

    ctl = XArmConnection.acquire(IP, model=MODEL)
    try:
        n0, t0 = ctl.reports, time.monotonic()
        time.sleep(1.0)
        rate = (ctl.reports - n0) / (time.monotonic() - t0)
        print(f"real-time report: {rate:.0f} Hz; fault: {ctl.fault()}")
        assert rate > 20
    finally:
        ctl.release()


def test_arm_reads_and_holds_then_moves_last_joint():
    arm = _node(f"ufactory.{MODEL}", enable_on_open=MOTION, disable_on_close=False)
    with lifecycle(arm):
        s = arm.cycle()
        assert s["connected"] and np.isfinite(s["joint_pos"]).all() and np.isfinite(s["eef_pose"]).all()
        if not MOTION:
            return
        nudge_last_joint(arm, timeout=5)


def test_gripper_opens_and_closes():
    if not GRIPPER:
        pytest.skip("set RIO_XARM_GRIPPER to the gripper driver on the tool connector")
    grip = _node(GRIPPER)
    with lifecycle(grip):
        w = grip.width
        cycle_gripper(grip, (w, 0.3 * w, w), tol=0.01 * w + 0.003)
