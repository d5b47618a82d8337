"""On a real Universal Robots arm. Skipped by default (marker `hardware`); run with the controller
reachable (PC on the robot's subnet, see the README):

    RIO_UR_IP=192.168.1.102 RIO_UR_MODEL=ur5e pytest plugins/rio-ur -m hardware
    # optional: RIO_UR_ALLOW_MOTION=1 lets the arm move its last joint by 0.1 rad and back (Remote
    #           Control on the pendant, space around the tool cleared, a hand on the e-stop),
    #           RIO_UR_GRIPPER=1 opens and closes a Robotiq gripper through the URCap socket.

Read-only unless motion is allowed. The first test uses the receive interface and the dashboard only
(Local mode is fine); the driver test opens ur-rtde's control interface, which uploads its control
script (Remote Control needed) but sends no target unless motion is allowed.
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from rio.testing import cycle_gripper, lifecycle, nudge_last_joint

pytestmark = pytest.mark.hardware

IP = os.environ.get("RIO_UR_IP")
MODEL = os.environ.get("RIO_UR_MODEL", "ur5e")
MOTION = os.environ.get("RIO_UR_ALLOW_MOTION") == "1"
GRIPPER = os.environ.get("RIO_UR_GRIPPER") == "1"


@pytest.fixture(autouse=True)
def need_ip():
    if not IP:
        pytest.skip("set RIO_UR_IP (and RIO_UR_MODEL) to run the UR hardware tests")


def test_rtde_streams_at_the_controller_rate_and_the_dashboard_answers():
    from dashboard_client import DashboardClient
    from rtde_receive import RTDEReceiveInterface

    r = RTDEReceiveInterface(IP)
    try:
        t0, wall0 = r.getTimestamp(), time.monotonic()
        time.sleep(1.0)
        elapsed = r.getTimestamp() - t0
        print(f"controller time advanced {elapsed:.3f} s in {time.monotonic() - wall0:.3f} s; "
              f"robot mode {r.getRobotMode()}, safety mode {r.getSafetyMode()}")
        assert elapsed > 0.5 and np.isfinite(r.getActualQ()).all() and len(r.getActualQ()) == 6
    finally:
        r.disconnect()
    d = DashboardClient(IP)
    d.connect()
    try:
        print(d.polyscopeVersion(), d.robotmode(), d.safetystatus(), "remote:", d.isInRemoteControl())
        assert d.robotmode().startswith("Robotmode:")
    finally:
        d.disconnect()


def test_arm_reads_then_moves_last_joint():
    from rio.conformance.driving import build_node, resolve_driver

    arm = build_node(resolve_driver(f"ur.{MODEL}"), {"ip": IP, "enable_on_open": MOTION, "disable_on_close": False},
                     "hw")
    with lifecycle(arm):
        s = arm.cycle()
        assert s["connected"] and np.isfinite(s["joint_pos"]).all() and np.isfinite(s["eef_pose"]).all()
        print(f"fault: {s['fault_code']}, speed slider {s['speed_scaling']:.2f}")
        if not MOTION:
            return
        nudge_last_joint(arm, timeout=6)


def test_urcap_gripper_opens_and_closes():
    if not (GRIPPER and MOTION):
        pytest.skip("set RIO_UR_GRIPPER=1 and RIO_UR_ALLOW_MOTION=1 to move a Robotiq gripper on the URCap")
    from rio.conformance.driving import build_node, resolve_driver

    grip = build_node(resolve_driver("robotiq.urcap"), {"host": IP}, "hw_gripper")
    with lifecycle(grip):
        w = grip.width
        cycle_gripper(grip, (w, 0.3 * w, w), tol=0.01 * w + 0.003)
