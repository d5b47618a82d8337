"""On a real Franka. Skipped by default (marker `hardware`); run with the robot reachable, FCI active:

    RIO_FRANKA_IP=172.16.0.2 RIO_FRANKA_MODEL=fr3 pytest plugins/rio-franka -m hardware
    # optional: RIO_FRANKA_ALLOW_MOTION=1 lets the arm turn its last joint by 0.1 rad and back (clear the
    #           space around the hand, keep the enabling device in hand), RIO_FRANKA_HAND=1 opens and
    #           closes the Franka Hand.

Read-only unless motion is allowed.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from rio.testing import cycle_gripper, lifecycle, nudge_last_joint

pytestmark = pytest.mark.hardware

IP = os.environ.get("RIO_FRANKA_IP")
MODEL = os.environ.get("RIO_FRANKA_MODEL", "fr3")
MOTION = os.environ.get("RIO_FRANKA_ALLOW_MOTION") == "1"
HAND = os.environ.get("RIO_FRANKA_HAND") == "1"


@pytest.fixture(autouse=True)
def need_ip():
    if not IP:
        pytest.skip("set RIO_FRANKA_IP (and RIO_FRANKA_MODEL) to run the Franka hardware tests")


def _node(driver: str, **fields):
    from rio.conformance.driving import build_node, resolve_driver

    return build_node(resolve_driver(driver), {"ip": IP, **fields}, "hw")


def test_arm_reads_and_holds_then_moves_last_joint():
    arm = _node(f"franka.{MODEL}", enable_on_open=MOTION, disable_on_close=False, relative_dynamics_factor=0.1)
    with lifecycle(arm):
        s = arm.cycle()
        assert s["connected"] and s["fault_code"] == 0, arm.faults.fault
        assert np.isfinite(s["joint_pos"]).all() and np.isfinite(s["eef_pose"]).all()
        if not MOTION:
            return
        nudge_last_joint(arm, timeout=6)


def test_hand_opens_and_closes():
    if not HAND:
        pytest.skip("set RIO_FRANKA_HAND=1 to move the Franka Hand")
    hand = _node("franka.hand")
    with lifecycle(hand):
        cycle_gripper(hand, (0.08, 0.02, 0.08), tol=0.003, seconds=0.5)
