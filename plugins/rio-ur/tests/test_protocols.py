"""Round trips through the unmodified ur-rtde objects against the emulated protocols (RTDE 30004 and
the Dashboard Server 29999): what a real UR would answer."""

from __future__ import annotations

import numpy as np

from rio.testing import wait_until


def test_rtde_receive_reads_the_emulated_state(emulator):
    from rtde_receive import RTDEReceiveInterface

    r = RTDEReceiveInterface(emulator.host)  # ur-rtde's default recipe, 500 Hz for an e-Series
    try:
        np.testing.assert_allclose(r.getActualQ(), emulator.state()["q"], atol=1e-6)
        np.testing.assert_allclose(r.getActualTCPPose(), emulator.state()["tcp_pose"], atol=1e-6)
        assert r.getRobotMode() == 7 and r.getSafetyMode() == 1 and r.getSpeedScaling() == 1.0
        t0 = r.getTimestamp()
        assert wait_until(lambda: r.getTimestamp() > t0 + 0.2, timeout=3)
        emulator.inject("protective_stop")
        assert wait_until(lambda: r.isProtectiveStopped(), timeout=2)
    finally:
        r.disconnect()


def test_dashboard_round_trips(emulator):
    from dashboard_client import DashboardClient

    d = DashboardClient(emulator.host)
    d.connect()
    try:
        assert d.isInRemoteControl()
        assert d.robotmode() == "Robotmode: RUNNING" and d.safetystatus() == "Safetystatus: NORMAL"
        d.powerOff()
        assert d.robotmode() == "Robotmode: POWER_OFF"
        d.powerOn()
        d.brakeRelease()
        assert d.robotmode() == "Robotmode: RUNNING"
        d.loadURP("pick.urp")
        d.play()
        assert d.programState().startswith("PLAYING") and "pick.urp" in d.getLoadedProgram()
        d.stop()
        assert d.programState().startswith("STOPPED")
    finally:
        d.disconnect()


def test_a_stalled_tick_follows_a_new_servo_target_only_from_when_it_arrived():
    """The emulator's tick thread descheduled for 50 ms, a far target arriving 10 ms before it runs again:
    the setpoint moves toward it for those 10 ms at most at the rated speed, never the whole stall
    (simulated time, so the figure is exact)."""
    from rio_ur.emulator.robot import URRobot
    from rio_ur.models import get_arm

    arm = get_arm("ur5e")
    robot = URRobot(arm)
    robot.control_clients = 1  # a control script holds the servo port: the arm can move
    robot.tick(0.002, 10.0)
    q0 = robot.q_cmd.copy()
    far = q0.copy()
    far[0] += 3.0
    assert robot.servo_j(far, 0.03, t=10.04)
    robot.tick(0.05, 10.05)
    moved = robot.q_cmd - q0
    assert 0 < moved[0] <= arm.max_speed[0] * 0.01 + 1e-12
    assert np.allclose(moved[1:], 0.0)
