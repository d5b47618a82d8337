"""On a real Kinova base. Skipped by default (marker `hardware`); run with the base reachable and
kortex_api installed:

    RIO_KINOVA_IP=192.168.1.10 RIO_KINOVA_MODEL=gen3 pytest plugins/rio-kinova -m hardware
    # optional: RIO_KINOVA_USER / RIO_KINOVA_PASSWORD (default admin/admin), RIO_KINOVA_ALLOW_MOTION=1
    #           lets the arm move its last joint by 0.1 rad and back (clear the space first),
    #           RIO_KINOVA_GRIPPER=1 opens and closes the Robotiq 2F-85.

Read-only unless motion is allowed.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from rio.testing import cycle_gripper, lifecycle, nudge_last_joint

pytestmark = pytest.mark.hardware

IP = os.environ.get("RIO_KINOVA_IP")
MODEL = os.environ.get("RIO_KINOVA_MODEL", "gen3")
MOTION = os.environ.get("RIO_KINOVA_ALLOW_MOTION") == "1"
GRIPPER = os.environ.get("RIO_KINOVA_GRIPPER") == "1"
ACCOUNT = {"username": os.environ.get("RIO_KINOVA_USER", "admin"),
           "password": os.environ.get("RIO_KINOVA_PASSWORD", "admin")}


@pytest.fixture(autouse=True)
def need_ip():
    if not IP:
        pytest.skip("set RIO_KINOVA_IP (and RIO_KINOVA_MODEL) to run the Kinova hardware tests")


def _node(driver: str, **fields):
    from rio.conformance.driving import build_node, resolve_driver

    return build_node(resolve_driver(driver), {"ip": IP, **ACCOUNT, **fields}, "hw")


def test_arm_reads_and_holds_then_moves_last_joint():
    arm = _node(f"kinova.{MODEL}", enable_on_open=MOTION, disable_on_close=False)
    with lifecycle(arm):
        s = arm.cycle()
        assert s["fault_code"] == 0 and np.isfinite(s["joint_pos"]).all() and np.isfinite(s["eef_pose"]).all()
        if not MOTION:
            return
        nudge_last_joint(arm, timeout=5)


def test_gripper_opens_and_closes():
    if not GRIPPER:
        pytest.skip("set RIO_KINOVA_GRIPPER=1 with a Robotiq 2F-85 on the arm")
    grip = _node("kinova.robotiq_2f85", model=MODEL)
    with lifecycle(grip):
        w = grip.width
        cycle_gripper(grip, (w, 0.3 * w, w), tol=0.004)
