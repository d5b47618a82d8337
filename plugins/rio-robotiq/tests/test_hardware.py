"""On real grippers. Skipped by default (marker `hardware`) and per transport unless its address is set:

    RIO_ROBOTIQ_PORT=/dev/ttyUSB0 pytest plugins/rio-robotiq -m hardware      # Robotiq, Modbus RTU
    RIO_ROBOTIQ_URCAP_HOST=192.168.1.10 pytest plugins/rio-robotiq -m hardware  # Robotiq through a UR's URCap
    RIO_DH_PORT=/dev/ttyUSB1 pytest plugins/rio-robotiq -m hardware           # DH AG-95 / AG-105-145
    # optional: RIO_ROBOTIQ_MODEL=2f140|hande, RIO_DH_MODEL=ag105,
    #           RIO_GRIPPER_ALLOW_MOTION=1 to let the grippers activate and move (keep hands and cables clear)

Without RIO_GRIPPER_ALLOW_MOTION only the status is read: activation and initialization move the
fingers through their stroke, so they are part of the motion tests. Positions are checked loosely
(3 mm): a unit's end counts differ from the manual's (see `open_count` / `closed_count`).
"""

from __future__ import annotations

import os

import pytest

from rio import clock
from rio.testing import lifecycle

pytestmark = pytest.mark.hardware

ROBOTIQ_PORT = os.environ.get("RIO_ROBOTIQ_PORT")
URCAP_HOST = os.environ.get("RIO_ROBOTIQ_URCAP_HOST")
DH_PORT = os.environ.get("RIO_DH_PORT")
ROBOTIQ_MODEL = os.environ.get("RIO_ROBOTIQ_MODEL", "2f85")
DH_MODEL = os.environ.get("RIO_DH_MODEL", "ag95")
MOTION = os.environ.get("RIO_GRIPPER_ALLOW_MOTION") == "1"
TOL = 0.003


def need(value: str | None, var: str, motion: bool = False) -> str:
    if not value:
        pytest.skip(f"set {var} to run this hardware test")
    if motion and not MOTION:
        pytest.skip("set RIO_GRIPPER_ALLOW_MOTION=1 to let the gripper activate and move")
    return value


def robotiq_status(link) -> None:
    """Open a Robotiq link, read the status once, close it."""
    link.open()
    try:
        st = link.status()
        print(f"Robotiq on {link.where}: {st}")
        assert 0 <= st.gPO <= 255 and st.gSTA in (0, 1, 3)
    finally:
        link.close()


def open_and_close(node) -> None:
    import time

    with lifecycle(node) as g:
        width = float(g.config.max_width)
        for target in (0.5 * width, width):
            g.handle_request({"width": target, "t_cmd_target": clock.now() + 1.0, "force": 0.0})
            t_end = time.monotonic() + 5.0
            while time.monotonic() < t_end:
                s = g.cycle()
                time.sleep(1.0 / g.rate_hz)
            print(f"{type(node).__name__}: target {target:.4f} m, measured {s['width']:.4f} m, state {s}")
            assert abs(s["width"] - target) < TOL
            assert s.get("fault", 0) == 0


def test_robotiq_rtu_status():
    from rio_robotiq.robotiq.rtu_link import RobotiqRtuLink

    port = need(ROBOTIQ_PORT, "RIO_ROBOTIQ_PORT")
    robotiq_status(RobotiqRtuLink(port, 9, baudrate=115200, timeout_s=0.2, label="Robotiq"))


def test_robotiq_rtu_moves():
    from rio_robotiq.robotiq.driver import RobotiqGripper

    open_and_close(RobotiqGripper(port=need(ROBOTIQ_PORT, "RIO_ROBOTIQ_PORT", motion=True), model=ROBOTIQ_MODEL))


def test_robotiq_urcap_status():
    from rio_robotiq.robotiq.urcap_link import RobotiqUrcapLink

    host = need(URCAP_HOST, "RIO_ROBOTIQ_URCAP_HOST")
    robotiq_status(RobotiqUrcapLink(host, 63352, timeout_s=1.0, label="Robotiq"))


def test_robotiq_urcap_moves():
    from rio_robotiq.robotiq.driver import RobotiqUrcapGripper

    open_and_close(RobotiqUrcapGripper(ip=need(URCAP_HOST, "RIO_ROBOTIQ_URCAP_HOST", motion=True),
                                       model=ROBOTIQ_MODEL))


def test_dh_status():
    from rio_robotiq.dh.registers import INIT_STATE
    from rio_robotiq.rtu import RtuClient

    port = need(DH_PORT, "RIO_DH_PORT")
    client = RtuClient(port, 1, label="DH gripper").open()
    try:
        init, grip, permille = client.read(INIT_STATE, 3)
        print(f"DH on {port}: init state {init}, grip state {grip}, position {permille} per mille")
        assert init in (0, 1, 2) and grip in (0, 1, 2, 3) and 0 <= permille <= 1000
    finally:
        client.close()


def test_dh_moves():
    from rio_robotiq.dh.driver import DhGripper

    open_and_close(DhGripper(port=need(DH_PORT, "RIO_DH_PORT", motion=True), model=DH_MODEL))
